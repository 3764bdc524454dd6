#!/usr/bin/env bash
# Generates the Python stubs of couplet's gRPC API from protocol/proto (into ./couplet/v1/).
set -euo pipefail
cd "$(dirname "$0")"
python3 -m grpc_tools.protoc -I ../../protocol/proto \
    --python_out=. --grpc_python_out=. couplet/v1/couplet.proto
