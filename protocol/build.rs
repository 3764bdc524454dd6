//! Compiles `proto/couplet/v1/*.proto` into Rust (prost messages, tonic client and
//! server) with protox, a protobuf compiler in Rust, so no system `protoc` is needed.
//! The encoded descriptor set is written next to the generated code for the server's
//! reflection service.

use prost::Message;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let proto = "proto/couplet/v1/couplet.proto";
    println!("cargo:rerun-if-changed=proto");
    let fds = protox::compile([proto], ["proto"])?;
    let out = PathBuf::from(std::env::var("OUT_DIR")?);
    std::fs::write(out.join("couplet_descriptor.bin"), fds.encode_to_vec())?;
    tonic_prost_build::configure().compile_fds(fds)?;
    Ok(())
}
