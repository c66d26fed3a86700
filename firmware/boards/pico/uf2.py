#!/usr/bin/env python3
"""Writes a UF2 file for the Pico's BOOTSEL drive (the RP2040 boot ROM's
USB mass-storage loader) from ELF files and raw images.

    uf2.py OUT.uf2 motet-pico-boot app.img@0x10100000 text:MTBRinst@0x10012000

An ELF contributes its loadable segments at their load (physical)
addresses; FILE@ADDR puts a raw file at ADDR; text:STRING@ADDR the
string's bytes (the bootloader's install request above). Everything must land in the
Pico's 2 MB of flash, and no two inputs may write the same byte.
"""

import struct
import sys

FLASH = (0x1000_0000, 0x1020_0000)
FAMILY_RP2040 = 0xE48B_FF56
MAGIC = (0x0A32_4655, 0x9E5D_5157, 0x0AB1_6F30)
FLAG_FAMILY = 0x0000_2000
PAGE = 256


def elf_segments(name, data):
    if data[4] != 1 or data[5] != 1:
        sys.exit(f"{name}: not a 32-bit little-endian ELF file")
    phoff, = struct.unpack_from("<I", data, 28)
    phentsize, phnum = struct.unpack_from("<HH", data, 42)
    for i in range(phnum):
        p_type, offset, _vaddr, paddr, filesz = struct.unpack_from(
            "<IIIII", data, phoff + i * phentsize)
        if p_type == 1 and filesz > 0:  # PT_LOAD with bytes in the file
            yield paddr, data[offset:offset + filesz]


def inputs(args):
    for arg in args:
        name, _, at = arg.rpartition("@") if "@" in arg else (arg, "", "")
        addr = None
        if at:
            try:
                addr = int(at, 0)
            except ValueError:
                sys.exit(f"{arg}: expected FILE@ADDRESS, e.g. app.img@0x10100000")
        if name.startswith("text:"):
            if addr is None:
                sys.exit(f"{arg}: expected text:STRING@ADDRESS")
            yield arg, addr, name[5:].encode()
            continue
        try:
            with open(name, "rb") as f:
                data = f.read()
        except OSError as e:
            sys.exit(f"{name}: {e.strerror}")
        if addr is not None:
            yield name, addr, data
        elif data.startswith(b"\x7fELF"):
            for addr, seg in elf_segments(name, data):
                yield name, addr, seg
        else:
            sys.exit(f"{name}: not an ELF file; give a raw file as {name}@ADDRESS")


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out, args = sys.argv[1], sys.argv[2:]
    pages = {}
    owner = {}
    for name, addr, data in inputs(args):
        if addr < FLASH[0] or addr + len(data) > FLASH[1]:
            sys.exit(f"{name}: {len(data)} bytes at {addr:#010x} are outside the flash "
                     f"({FLASH[0]:#010x}..{FLASH[1]:#010x})")
        for i, b in enumerate(data):
            a = addr + i
            if a in owner:
                sys.exit(f"{name}: byte {a:#010x} is also {owner[a]}'s")
            owner[a] = name
            page = pages.setdefault(a & ~(PAGE - 1), bytearray(b"\xff" * PAGE))
            page[a % PAGE] = b
    blocks = sorted(pages)
    with open(out, "wb") as f:
        for n, addr in enumerate(blocks):
            f.write(struct.pack("<IIIIIIII", MAGIC[0], MAGIC[1], FLAG_FAMILY, addr, PAGE,
                                n, len(blocks), FAMILY_RP2040))
            f.write(bytes(pages[addr]).ljust(476, b"\0"))
            f.write(struct.pack("<I", MAGIC[2]))
    print(f"wrote {out}: {len(blocks)} blocks, {len(owner)} bytes, "
          f"{blocks[0]:#010x}..{blocks[-1] + PAGE:#010x}")


if __name__ == "__main__":
    main()
