//! Two runtimes from `imxrt-rt`, one linker script per binary:
//!
//! - the bootloader at the start of flash, with the FlexSPI configuration
//!   block and the image vector table the i.MX RT boot ROM reads;
//! - the application in its slot (`src/layout.rs`: the payload part of the
//!   application slot), started by the bootloader, with no boot header.
//!
//! Both give FlexRAM the same banks (instructions in ITCM, data and stack in
//! DTCM), so the application's start-up finds memory as the bootloader left
//! it. On the host (the crate's tests) nothing is linked.

use imxrt_rt::{Family, FlexRamBanks, Memory, RuntimeBuilder};

#[path = "src/link.rs"]
mod link;

fn runtime(mut rt: RuntimeBuilder, stack: usize, script: &str) {
    rt.flexram_banks(FlexRamBanks {
        ocram: 0,
        itcm: 6,
        dtcm: 10,
    })
    .text(Memory::Itcm)
    .vectors(Memory::Dtcm)
    .rodata(Memory::Ocram)
    .data(Memory::Dtcm)
    .bss(Memory::Dtcm)
    .uninit(Memory::Ocram)
    .stack(Memory::Dtcm)
    .stack_size(stack)
    .heap(Memory::Dtcm)
    .heap_size(0)
    .linker_script_name(script)
    .build()
    .expect("imxrt-rt refused the runtime");
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/link.rs");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    runtime(
        RuntimeBuilder::from_flexspi(Family::Imxrt1060, link::FLASH_LEN as usize),
        16 * 1024,
        "teensy41-boot.x",
    );
    // The node's endpoint lives on the stack (about 56 KB: queue, graph,
    // link, services).
    runtime(
        RuntimeBuilder::in_flash(Family::Imxrt1060, link::APP_LEN as usize, link::APP_OFFSET),
        96 * 1024,
        "teensy41-node.x",
    );
    println!("cargo:rustc-link-arg-bin=motet-teensy41-boot=-Tteensy41-boot.x");
    println!("cargo:rustc-link-arg-bin=motet-teensy41-node=-Tteensy41-node.x");
}
