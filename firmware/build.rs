//! Puts the workspace's top-level `memory.x` on the linker search path
//! (cortex-m-rt's `link.x` includes it).

use std::{env, path::PathBuf};

fn main() {
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let top = manifest.parent().expect("firmware/ lives in the workspace").to_path_buf();
    println!("cargo:rustc-link-search={}", top.display());
    println!("cargo:rerun-if-changed={}", top.join("memory.x").display());
    println!("cargo:rerun-if-changed=build.rs");
}
