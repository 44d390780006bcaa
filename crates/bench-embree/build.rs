//! Detects Embree 3 (Debian's `libembree-dev`: `embree3/rtcore.h` and `libembree3.so`) and,
//! when found, links it and sets `cfg(embree)`. `EMBREE_DIR` points at a non-standard install
//! (`include/` and `lib/` below it); `LUXBAKE_NO_EMBREE=1` builds without it.

use std::path::{Path, PathBuf};

fn main() {
    println!("cargo::rustc-check-cfg=cfg(embree)");
    println!("cargo::rerun-if-env-changed=EMBREE_DIR");
    println!("cargo::rerun-if-env-changed=LUXBAKE_NO_EMBREE");
    if std::env::var_os("LUXBAKE_NO_EMBREE").is_some() {
        return;
    }
    let mut roots: Vec<PathBuf> = Vec::new();
    if let Some(dir) = std::env::var_os("EMBREE_DIR") {
        roots.push(PathBuf::from(dir));
    }
    roots.extend(["/usr", "/usr/local"].map(PathBuf::from));
    let multiarch = format!("lib/{}-linux-gnu", std::env::consts::ARCH);
    for root in roots {
        let header = root.join("include/embree3/rtcore.h");
        println!("cargo::rerun-if-changed={}", header.display());
        if !header.is_file() {
            continue;
        }
        let lib = ["lib", "lib64", multiarch.as_str()]
            .iter()
            .map(|l| root.join(l))
            .find(|l| has_library(l));
        if let Some(lib) = lib {
            println!("cargo::rustc-link-search=native={}", lib.display());
            println!("cargo::rustc-link-lib=dylib=embree3");
            println!("cargo::rustc-cfg=embree");
            return;
        }
    }
}

fn has_library(dir: &Path) -> bool {
    dir.join("libembree3.so").is_file()
}
