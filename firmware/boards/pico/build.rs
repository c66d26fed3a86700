//! Memory layouts for the two binaries: cortex-m-rt's `link.x` includes
//! the `memory.x` found first on the linker's search path, so each binary
//! gets its own folder with its file (`memory-boot.x`, `memory-node.x`).

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    // The drivers and binaries build for the RP2040 only (host builds are
    // the tests of the pin table and the layout).
    if std::env::var("CARGO_CFG_TARGET_ARCH").as_deref() != Ok("arm") {
        return;
    }
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    for (bin, file) in [
        ("motet-pico-boot", "memory-boot.x"),
        ("motet-pico-node", "memory-node.x"),
    ] {
        println!("cargo:rerun-if-changed={file}");
        let dir = out.join(bin);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::copy(file, dir.join("memory.x")).unwrap();
        println!("cargo:rustc-link-arg-bin={bin}=-L{}", dir.display());
        println!("cargo:rustc-link-arg-bin={bin}=-Tlink.x");
    }
}
