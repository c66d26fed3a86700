//! A firmware ELF file as the flat binary a bootloader installs: every
//! loadable segment's file bytes at its load (physical) address, from the
//! lowest to the highest, gaps filled with zeros (what `objcopy -O binary`
//! writes). Initialised data is loaded from flash, so its load address, not
//! its RAM address, is where it goes.

use anyhow::{bail, Context, Result};
use object::elf::PT_LOAD;
use object::read::elf::{ElfFile32, ProgramHeader};
use object::LittleEndian;

/// The flat binary and the address its first byte loads at.
pub fn flatten(file: &[u8]) -> Result<(Vec<u8>, u32)> {
    let elf = ElfFile32::<LittleEndian>::parse(file)
        .context("not a 32-bit little-endian ELF file (a Cortex-M firmware)")?;
    let e = LittleEndian;
    let mut parts = Vec::new();
    for ph in elf.elf_program_headers() {
        if ph.p_type(e) != PT_LOAD || ph.p_filesz(e) == 0 {
            continue;
        }
        let data = ph
            .data(e, file)
            .map_err(|_| anyhow::anyhow!("a loadable segment lies outside the file"))?;
        parts.push((ph.p_paddr(e), data));
    }
    parts.sort_by_key(|p| p.0);
    let Some(&(start, _)) = parts.first() else {
        bail!("no loadable segment");
    };
    let end = parts
        .iter()
        .map(|(a, d)| *a as u64 + d.len() as u64)
        .max()
        .unwrap_or(start as u64);
    let len = end - start as u64;
    if len > 16 << 20 {
        bail!("its loadable segments span {len} bytes (they are not one firmware image)");
    }
    let mut out = vec![0u8; len as usize];
    for (a, d) in parts {
        let at = (a - start) as usize;
        out[at..at + d.len()].copy_from_slice(d);
    }
    Ok((out, start))
}
