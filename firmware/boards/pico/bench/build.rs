//! The measurement runs on QEMU's `microbit` (an nRF51822: Cortex-M0),
//! started with room for the node: `-global nrf51-soc.flash-size=1048576
//! -global nrf51-soc.sram-size=262144` (the Pico has 2 MB flash and 264 KB
//! RAM). With the `float-calls` feature the linker wraps the compiler's
//! f64 routines so that the bench counts their calls.

use std::path::PathBuf;

/// The f64 (and f32) routines the node's code calls on ARMv6-M.
pub const FLOAT_ROUTINES: &[&str] = &[
    "__aeabi_dadd",
    "__aeabi_dsub",
    "__aeabi_dmul",
    "__aeabi_ddiv",
    "__aeabi_dcmpeq",
    "__aeabi_dcmplt",
    "__aeabi_dcmple",
    "__aeabi_dcmpgt",
    "__aeabi_dcmpge",
    "__aeabi_dcmpun",
    "__aeabi_d2iz",
    "__aeabi_d2uiz",
    "__aeabi_d2lz",
    "__aeabi_d2ulz",
    "__aeabi_i2d",
    "__aeabi_ui2d",
    "__aeabi_l2d",
    "__aeabi_ul2d",
    "__aeabi_f2d",
    "__aeabi_d2f",
];

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    std::fs::write(
        out.join("memory.x"),
        "MEMORY {\n  FLASH : ORIGIN = 0x00000000, LENGTH = 1M\n  RAM : ORIGIN = 0x20000000, LENGTH = 256K\n}\n",
    )
    .unwrap();
    // Interrupt handlers are named in the binary's vector table.
    std::fs::write(out.join("device.x"), "").unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    if std::env::var_os("CARGO_FEATURE_FLOAT_CALLS").is_some() {
        for r in FLOAT_ROUTINES {
            println!("cargo:rustc-link-arg-bins=--wrap={r}");
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
}
