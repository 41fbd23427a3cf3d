//! Puts the memory layout where the linker finds it as memory.x, for cortex-m-rt's link.x
//! (microcontroller builds): the example target's (memory/example.x), or with the `mps2-an386`
//! feature the layout of the board qemu emulates for the robot-in-the-loop rig. The layouts live
//! in memory/ because the linker would take a memory.x in the crate's root before this one.

use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let layout = if env::var_os("CARGO_FEATURE_MPS2_AN386").is_some() {
        "memory/mps2-an386.x"
    } else {
        "memory/example.x"
    };
    fs::copy(layout, out.join("memory.x")).expect("copy the memory layout");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory");
    println!("cargo:rerun-if-changed=build.rs");
}
