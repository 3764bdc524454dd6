#!/usr/bin/env python3
"""Creates a run on a `couplet serve`, watches it to its end and prints body 0's trajectory.

    pip install -r requirements.txt && ./generate.sh
    couplet serve &                      # in the repository root
    python3 trajectory.py ../../scenes/settling-sphere.toml --set fluid.spacing=0.004

Each line is one coupling window: time (s), position (m), velocity (m/s) and the fluid
force (N) on the body. The simulation never waits for this client; if it falls behind,
the server says how many windows it missed.
"""

import argparse
import sys

import grpc

from couplet.v1 import couplet_pb2 as pb
from couplet.v1 import couplet_pb2_grpc as rpc


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", help="scene file (TOML)")
    ap.add_argument("--server", default="127.0.0.1:50051")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="scene override, as `couplet run --set`")
    ap.add_argument("--body", type=int, default=0, help="which body to print")
    args = ap.parse_args()

    overrides = []
    for kv in args.set:
        path, sep, value = kv.partition("=")
        if not sep:
            ap.error(f"--set {kv}: expected PATH=VALUE")
        overrides.append(pb.Override(path=path.strip(), value=value.strip()))

    with grpc.insecure_channel(args.server) as channel:
        api = rpc.CoupletStub(channel)
        with open(args.scene, encoding="utf-8") as f:
            run = api.CreateRun(pb.CreateRunRequest(scene_toml=f.read(), overrides=overrides))
        print(f"# run {run.run_id}: {run.scene_name}, output in {run.output_dir}", file=sys.stderr)
        ref = pb.RunRequest(run_id=run.run_id)
        events = api.WatchRun(ref)  # subscribe before starting: no window is lost
        api.StartRun(ref)
        print("# t [s]  x y z [m]  vx vy vz [m/s]  Fx Fy Fz [N]")
        for event in events:
            if event.HasField("ended"):
                end = event.ended
                state = pb.RunState.Name(end.state)
                print(f"# {state} after {end.windows_done} windows, {end.wall_seconds:.1f} s wall"
                      + (f": {end.error}" if end.error else ""), file=sys.stderr)
                return 0 if end.state == pb.RUN_STATE_FINISHED else 1
            frame = event.frame
            if frame.missed:
                print(f"# missed {frame.missed} windows", file=sys.stderr)
            body = next((b for b in frame.bodies if b.body == args.body), None)
            if body is None:
                continue
            p, v, F = body.position, body.linear_velocity, body.force
            print(f"{frame.time:.6e}  {p.x:.6e} {p.y:.6e} {p.z:.6e}  "
                  f"{v.x:.6e} {v.y:.6e} {v.z:.6e}  {F.x:.6e} {F.y:.6e} {F.z:.6e}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
