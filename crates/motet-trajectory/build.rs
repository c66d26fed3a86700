//! Finds out whether the target has a double-precision square root in
//! hardware that `math::sqrt` may use: Cortex-M7 boards built with
//! `-C target-cpu=cortex-m7` (FPv5-D16, `vsqrt.f64`). Stable Rust does not
//! expose Arm FPU features to `cfg`, so a two-line probe is compiled with
//! the build's own target and flags; where it compiles, `hw_sqrt_f64` is set.
//! IEEE square roots are correctly rounded, so the instruction and `libm`
//! give the same bits.

use std::env;
use std::fs;
use std::path::PathBuf;
use std::process::Command;

const PROBE: &str = r#"#![no_std]
pub fn probe(x: f64) -> f64 {
    let r: f64;
    unsafe { core::arch::asm!("vsqrt.f64 {0}, {1}", out(dreg_low16) r, in(dreg_low16) x) };
    r
}
"#;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(hw_sqrt_f64)");
    println!("cargo::rerun-if-changed=build.rs");
    if env::var("CARGO_CFG_TARGET_ARCH").as_deref() != Ok("arm") {
        return;
    }
    let (Ok(rustc), Ok(target), Ok(out)) =
        (env::var("RUSTC"), env::var("TARGET"), env::var("OUT_DIR"))
    else {
        return;
    };
    let out = PathBuf::from(out);
    let src = out.join("probe_vsqrt.rs");
    if fs::write(&src, PROBE).is_err() {
        return;
    }
    let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    let ok = Command::new(rustc)
        .args([
            "--crate-type=lib",
            "--emit=obj",
            "--crate-name=probe_vsqrt",
            "--target",
        ])
        .arg(&target)
        .arg("--out-dir")
        .arg(&out)
        .args(flags.split('\x1f').filter(|f| !f.is_empty()))
        .arg(&src)
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        println!("cargo::rustc-cfg=hw_sqrt_f64");
    }
}
