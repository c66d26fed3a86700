//! The pin table and the flash layout, checked on the host: what the
//! drivers and the linker scripts rely on.

extern crate std;

use crate::layout::{BOOTLOADER, FLASH_LEN, LAYOUT, PAGE, RAM, SECTOR, XIP_BASE};
use crate::pin_table::*;
use motet_firmware::board::Region;
use std::collections::BTreeMap;
use std::string::String;
use std::vec::Vec;

#[test]
fn every_pin_has_one_job_and_exists() {
    let mut jobs: BTreeMap<u8, Vec<&str>> = BTreeMap::new();
    let mut add = |pins: &[u8], what: &'static str| {
        for &p in pins {
            jobs.entry(p).or_default().push(what);
        }
    };
    add(&STEP, "step");
    add(&DIR, "dir");
    add(&TOOL, "tool");
    add(&ANALOG, "analog");
    add(&[BUTTON], "button");
    add(&[LED], "led");
    for (pin, what) in &jobs {
        assert_eq!(what.len(), 1, "GP{pin} is used for {what:?}");
        assert!(*pin <= 29, "GP{pin} does not exist");
    }
    // GP23 (supply mode) and GP24 (VBUS sense) are the Pico's own; GP25
    // is its LED, GP0/GP1 stay free for a debug UART.
    for reserved in [0, 1, 23, 24] {
        assert!(!jobs.contains_key(&reserved), "GP{reserved} is reserved");
    }
    assert_eq!(LED, 25);
}

#[test]
fn channels_tools_and_masks_agree() {
    assert_eq!(STEP.len(), CHANNELS);
    assert_eq!(DIR.len(), CHANNELS);
    assert_eq!(TOOL.len(), TOOLS);
    for ch in 0..CHANNELS {
        assert_eq!(STEP_MASK[ch], 1 << STEP[ch]);
        assert_eq!(DIR_MASK[ch], 1 << DIR[ch]);
    }
}

#[test]
fn tools_share_the_slice_main_sets_up() {
    let mut channels = Vec::new();
    for &t in &TOOL {
        let (slice, ch) = pwm_of(t);
        assert_eq!(slice, TOOL_SLICE, "GP{t} is on PWM slice {slice}");
        channels.push(ch);
    }
    channels.sort();
    channels.dedup();
    assert_eq!(channels.len(), TOOL.len(), "two tools on one PWM channel");
    // The datasheet's table: GP14 is PWM7 A, GP15 PWM7 B, GP0 PWM0 A,
    // GP17 PWM0 B.
    for (gpio, want) in [
        (14, (7, 0)),
        (15, (7, 1)),
        (0, (0, 0)),
        (17, (0, 1)),
        (29, (6, 1)),
    ] {
        assert_eq!(pwm_of(gpio), want, "GP{gpio}");
    }
}

#[test]
fn analog_pins_are_adc_inputs() {
    for &a in &ANALOG {
        assert!(adc_of(a).is_some(), "GP{a} has no ADC input");
    }
    for (gpio, want) in [(25, None), (26, Some(0)), (29, Some(3)), (30, None)] {
        assert_eq!(adc_of(gpio), want, "GP{gpio}");
    }
}

fn regions() -> [(&'static str, Region); 5] {
    [
        ("bootloader", BOOTLOADER),
        ("identity", LAYOUT.identity),
        ("request", LAYOUT.request),
        ("app", LAYOUT.app),
        ("staging", LAYOUT.staging),
    ]
}

#[test]
fn flash_regions_are_sectors_inside_the_chip_and_apart() {
    for (name, r) in regions() {
        assert_eq!(r.start % SECTOR, 0, "{name} starts inside a sector");
        assert_eq!(r.len % SECTOR, 0, "{name} ends inside a sector");
        assert!(
            r.len > 0 && r.end() <= FLASH_LEN,
            "{name} is outside the flash"
        );
    }
    let all = regions();
    for (i, (a, ra)) in all.iter().enumerate() {
        for (b, rb) in &all[i + 1..] {
            assert!(
                ra.end() <= rb.start || rb.end() <= ra.start,
                "{a} overlaps {b}"
            );
        }
    }
    assert_eq!(LAYOUT.identity.len, 2 * SECTOR);
    assert_eq!(LAYOUT.request.len, SECTOR);
}

#[test]
fn the_application_runs_where_its_slot_puts_it() {
    assert_eq!(
        LAYOUT.app_exec,
        XIP_BASE + LAYOUT.app.start + LAYOUT.app_header
    );
    // The M0+'s VTOR holds multiples of 256; the header is whole pages.
    assert_eq!(LAYOUT.app_exec % 256, 0);
    assert_eq!(LAYOUT.app_header % PAGE, 0);
    assert_eq!(LAYOUT.ram, RAM);
}

/// `NAME : ORIGIN = X, LENGTH = Y` lines of a memory.x.
fn memory(text: &str) -> BTreeMap<String, (u32, u32)> {
    let num = |s: &str| {
        let s = s.trim();
        match s.strip_prefix("0x") {
            Some(h) => u32::from_str_radix(h, 16).unwrap(),
            None => s.parse().unwrap(),
        }
    };
    let mut m = BTreeMap::new();
    for line in text.lines() {
        let Some((name, rest)) = line.split_once(':') else {
            continue;
        };
        let Some(rest) = rest.trim().strip_prefix("ORIGIN =") else {
            continue;
        };
        let (origin, len) = rest
            .split_once(", LENGTH =")
            .expect("ORIGIN = X, LENGTH = Y");
        m.insert(name.trim().into(), (num(origin), num(len)));
    }
    m
}

#[test]
fn the_linker_scripts_match_the_layout() {
    let boot = memory(include_str!("../memory-boot.x"));
    let node = memory(include_str!("../memory-node.x"));
    let ram = (RAM.0, RAM.1 - RAM.0);
    // boot2 first (the ROM reads 256 bytes there), the bootloader after
    // it, all inside the bootloader's region.
    assert_eq!(boot["BOOT2"], (XIP_BASE, 256));
    assert_eq!(boot["FLASH"].0, XIP_BASE + 256);
    assert_eq!(
        boot["FLASH"].0 + boot["FLASH"].1,
        XIP_BASE + BOOTLOADER.end()
    );
    assert_eq!(boot["RAM"], ram);
    // The application: linked at `app_exec`, as long as the slot's payload.
    assert_eq!(node["FLASH"].0, LAYOUT.app_exec);
    assert_eq!(node["FLASH"].1, LAYOUT.app.len - LAYOUT.app_header);
    assert_eq!(node["RAM"], ram);
}
