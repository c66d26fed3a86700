//! Memory layouts for the three binaries (cortex-m-rt's `link.x` includes
//! the `memory.x` found first on the linker's search path: each binary gets
//! its own folder). The addresses are `src/layout.rs`'s.

use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let layouts = [
        // The bootloader at the reset vector, in the SSRAM QEMU loads
        // `-kernel` into.
        (
            "motet-mps2-boot",
            "MEMORY {\n  FLASH : ORIGIN = 0x00000000, LENGTH = 64K\n  RAM : ORIGIN = 0x20000000, LENGTH = 512K\n}\n",
        ),
        // The application where the bootloader installs it: the payload
        // part of the application slot in the emulated flash.
        (
            "motet-mps2-node",
            "MEMORY {\n  FLASH : ORIGIN = 0x60010100, LENGTH = 512K - 256\n  RAM : ORIGIN = 0x20000000, LENGTH = 512K\n}\n",
        ),
        // Measurements run alone, loaded as the kernel.
        (
            "motet-mps2-bench",
            "MEMORY {\n  FLASH : ORIGIN = 0x00000000, LENGTH = 1M\n  RAM : ORIGIN = 0x20000000, LENGTH = 512K\n}\n",
        ),
    ];
    for (bin, memory) in layouts {
        let dir = out.join(bin);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("memory.x"), memory).unwrap();
        println!("cargo:rustc-link-arg-bin={bin}=-L{}", dir.display());
        println!("cargo:rustc-link-arg-bin={bin}=-Tlink.x");
    }
    // Interrupt handlers are named in each binary's vector table.
    std::fs::write(out.join("device.x"), "").unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
}
