//! Puts the repository's memory.x (settings sectors carved out) on the linker search path.

use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    let memory_x = fs::read("../memory.x").expect("read ../memory.x");
    fs::write(out.join("memory.x"), memory_x).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=../boards");
    println!("cargo:rerun-if-changed=build.rs");
}
