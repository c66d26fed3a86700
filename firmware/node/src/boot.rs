//! The bootloader's part that every board shares: the application's
//! request to install what it staged, the checks an image passes before it
//! is installed or started, and the copy into the application slot.
//!
//! A board's bootloader binary, on every start: if a request is pending,
//! [`install`] the staged image (checked first; the old application stays
//! when the check fails) and [`clear_request`]; then, if the application
//! slot [`check_installed`] passes, start it; otherwise install the image
//! its programmer left (a factory image), if any.

use crate::board::{FlashPages, Layout};
use motet_node::storage::StorageError;
use motet_wire::frame::Crc32c;
use motet_wire::image::{ImageError, ImageHeader, MAX_HEADER_LEN};

/// Why an image is not installed or started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BootError {
    Image(ImageError),
    /// Built for another board, or (format 1) for none.
    WrongBoard,
    /// For another kind of node.
    WrongKind,
    /// Larger than the application slot.
    TooLarge,
    /// The payload does not start with a vector table for this slot (its
    /// stack in the board's RAM, its reset handler in the payload).
    BadVectors,
    Storage(StorageError),
    /// The copy in the application slot does not read back as the source.
    CopyDiffers,
}

impl From<StorageError> for BootError {
    fn from(e: StorageError) -> Self {
        BootError::Storage(e)
    }
}

impl core::fmt::Display for BootError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BootError::Image(e) => write!(f, "{e}"),
            BootError::WrongBoard => f.write_str("image for another board"),
            BootError::WrongKind => f.write_str("image for another kind of node"),
            BootError::TooLarge => f.write_str("image larger than the application slot"),
            BootError::BadVectors => f.write_str("payload is not an application for this slot"),
            BootError::Storage(e) => write!(f, "{e}"),
            BootError::CopyDiffers => f.write_str("installed copy differs from the image"),
        }
    }
}

const REQUEST: [u8; 8] = *b"MTBRinst";

/// The application asks the bootloader to install the staged image.
pub fn request_install<F: FlashPages>(flash: &mut F, layout: &Layout) -> Result<(), BootError> {
    flash.erase(layout.request.start)?;
    flash.program(layout.request.start, &REQUEST)?;
    Ok(())
}

/// Whether an install is requested.
pub fn requested<F: FlashPages>(flash: &F, layout: &Layout) -> bool {
    let mut b = [0u8; 8];
    flash.read(layout.request.start, &mut b).is_ok() && b == REQUEST
}

pub fn clear_request<F: FlashPages>(flash: &mut F, layout: &Layout) -> Result<(), BootError> {
    flash.erase(layout.request.start)?;
    Ok(())
}

fn read_header<F: FlashPages>(flash: &F, at: u32) -> Result<ImageHeader, BootError> {
    let mut head = [0u8; MAX_HEADER_LEN];
    flash.read(at, &mut head)?;
    ImageHeader::parse(&head).map_err(BootError::Image)
}

fn crc<F: FlashPages>(flash: &F, at: u32, len: u32) -> Result<u32, BootError> {
    let mut c = Crc32c::new();
    let mut buf = [0u8; 256];
    let mut done = 0;
    while done < len {
        let n = ((len - done) as usize).min(buf.len());
        flash.read(at + done, &mut buf[..n])?;
        c.update(&buf[..n]);
        done += n as u32;
    }
    Ok(c.finish())
}

/// What an image must be to run on this board: its header, its payload's
/// CRC, and a vector table for the application slot.
fn check<F: FlashPages>(
    flash: &F,
    header_at: u32,
    payload_at: u32,
    layout: &Layout,
    board: &str,
    kind: &str,
) -> Result<ImageHeader, BootError> {
    let h = read_header(flash, header_at)?;
    if h.board.as_deref() != Some(board) {
        return Err(BootError::WrongBoard);
    }
    if h.kind.as_str() != kind {
        return Err(BootError::WrongKind);
    }
    if h.payload_len > layout.app.len - layout.app_header {
        return Err(BootError::TooLarge);
    }
    let actual = crc(flash, payload_at, h.payload_len)?;
    if actual != h.payload_crc {
        return Err(BootError::Image(ImageError::CrcMismatch {
            expected: h.payload_crc,
            actual,
        }));
    }
    let mut v = [0u8; 8];
    if h.payload_len < 8 {
        return Err(BootError::BadVectors);
    }
    flash.read(payload_at, &mut v)?;
    let sp = u32::from_le_bytes([v[0], v[1], v[2], v[3]]);
    let reset = u32::from_le_bytes([v[4], v[5], v[6], v[7]]);
    let code = layout.app_exec..layout.app_exec + h.payload_len;
    let stack_ok = sp % 8 == 0 && sp > layout.ram.0 && sp <= layout.ram.1;
    if !stack_ok || reset & 1 == 0 || !code.contains(&(reset & !1)) {
        return Err(BootError::BadVectors);
    }
    Ok(h)
}

/// Checks the image staged (contiguous, as uploaded) at `at` in `src`.
pub fn check_staged<F: FlashPages>(
    src: &F,
    at: u32,
    layout: &Layout,
    board: &str,
    kind: &str,
) -> Result<ImageHeader, BootError> {
    let h = read_header(src, at)?;
    check(src, at, at + h.header_len() as u32, layout, board, kind)
}

/// Checks the installed application (header at the slot's start, payload
/// where it runs).
pub fn check_installed<F: FlashPages>(
    flash: &F,
    layout: &Layout,
    board: &str,
    kind: &str,
) -> Result<ImageHeader, BootError> {
    check(
        flash,
        layout.app.start,
        layout.app.start + layout.app_header,
        layout,
        board,
        kind,
    )
}

/// The installed image's header, unchecked (the bootloader checked it
/// before starting the application): the application reports its version.
pub fn installed_header<F: FlashPages>(flash: &F, layout: &Layout) -> Option<ImageHeader> {
    read_header(flash, layout.app.start).ok()
}

/// Installs the image staged at `at` in `src` (the staging area, or where
/// a programmer left a factory image) into the application slot of `dst`,
/// once it passes the checks; then checks the copy.
pub fn install<S: FlashPages, F: FlashPages>(
    src: &S,
    at: u32,
    dst: &mut F,
    layout: &Layout,
    board: &str,
    kind: &str,
) -> Result<ImageHeader, BootError> {
    let h = check_staged(src, at, layout, board, kind)?;
    let header_len = h.header_len() as u32;
    let total = layout.app_header + h.payload_len;
    let mut erased = 0;
    while erased < total {
        dst.erase(layout.app.start + erased)?;
        erased += F::SECTOR;
    }
    let mut buf = [0u8; 256];
    let mut copy = |from: u32, to: u32, len: u32, dst: &mut F| -> Result<(), BootError> {
        let mut done = 0;
        while done < len {
            let n = ((len - done) as usize).min(buf.len());
            src.read(from + done, &mut buf[..n])?;
            dst.program(to + done, &buf[..n])?;
            done += n as u32;
        }
        Ok(())
    };
    copy(at, layout.app.start, header_len, dst)?;
    copy(
        at + header_len,
        layout.app.start + layout.app_header,
        h.payload_len,
        dst,
    )?;
    match check_installed(dst, layout, board, kind) {
        Ok(i) if i == h => Ok(h),
        _ => Err(BootError::CopyDiffers),
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::board::Region;
    use crate::store::tests::MemFlash;
    use motet_wire::service::Version;
    use std::vec;
    use std::vec::Vec;

    const LAYOUT: Layout = Layout {
        identity: Region { start: 0, len: 512 },
        request: Region {
            start: 512,
            len: 256,
        },
        app: Region {
            start: 1024,
            len: 4096,
        },
        app_header: 256,
        app_exec: 0x6000_0500,
        ram: (0x2000_0000, 0x2008_0000),
        staging: Region {
            start: 5120,
            len: 4096,
        },
    };

    /// A payload with a vector table for LAYOUT's slot.
    fn app(len: usize, salt: u8) -> Vec<u8> {
        let mut p: Vec<u8> = (0..len).map(|i| (i as u8) ^ salt).collect();
        p[0..4].copy_from_slice(&0x2008_0000u32.to_le_bytes());
        p[4..8].copy_from_slice(&(0x6000_0500u32 + 0x41).to_le_bytes());
        p
    }

    fn image(board: Option<&str>, kind: &str, payload: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; MAX_HEADER_LEN + payload.len()];
        let v = Version {
            major: 1,
            minor: 2,
            patch: 3,
        };
        let n = motet_wire::image::build(kind, board, v, payload, &mut out).unwrap();
        out.truncate(n);
        out
    }

    fn stage(flash: &mut MemFlash, img: &[u8]) {
        let mut s = crate::staging::Staging::new(flash.clone(), LAYOUT.staging);
        for (i, c) in img.chunks(128).enumerate() {
            motet_node::storage::Flash::write(&mut s, i as u32 * 128, c).unwrap();
        }
    }

    #[test]
    fn only_a_good_image_for_this_board_replaces_the_application() {
        let mut flash = MemFlash::new(10240);
        let good = image(Some("qemu"), "stepper", &app(1500, 1));
        stage(&mut flash, &good);
        let h = install(
            &flash.clone(),
            LAYOUT.staging.start,
            &mut flash,
            &LAYOUT,
            "qemu",
            "stepper",
        )
        .unwrap();
        assert_eq!(
            check_installed(&flash, &LAYOUT, "qemu", "stepper"),
            Ok(h.clone())
        );
        let installed = flash.bytes.borrow()[1024 + 256..1024 + 256 + 1500].to_vec();
        assert_eq!(installed, app(1500, 1));

        let mut junk = app(1500, 2);
        junk[4..8].copy_from_slice(&0x0800_0001u32.to_le_bytes());
        let mut flipped = image(Some("qemu"), "stepper", &app(1500, 3));
        flipped[700] ^= 4;
        // (staged image, why it is refused)
        let cases = [
            (
                image(Some("pico"), "stepper", &app(1500, 2)),
                BootError::WrongBoard,
            ),
            (image(None, "stepper", &app(1500, 2)), BootError::WrongBoard),
            (
                image(Some("qemu"), "laser", &app(1500, 2)),
                BootError::WrongKind,
            ),
            (
                image(Some("qemu"), "stepper", &app(4000, 2)),
                BootError::TooLarge,
            ),
            (image(Some("qemu"), "stepper", &junk), BootError::BadVectors),
            (
                flipped.clone(),
                BootError::Image(ImageError::CrcMismatch {
                    expected: motet_wire::frame::crc32c(&app(1500, 3)),
                    actual: motet_wire::frame::crc32c(&flipped[56..]),
                }),
            ),
            (vec![0xFF; 64], BootError::Image(ImageError::BadMagic)),
        ];
        for (img, want) in cases {
            stage(&mut flash, &img);
            let before = flash.bytes.borrow().clone();
            let got = install(
                &flash.clone(),
                LAYOUT.staging.start,
                &mut flash,
                &LAYOUT,
                "qemu",
                "stepper",
            );
            assert_eq!(got, Err(want));
            assert_eq!(*flash.bytes.borrow(), before, "{want:?}: nothing written");
            assert_eq!(
                check_installed(&flash, &LAYOUT, "qemu", "stepper"),
                Ok(h.clone())
            );
        }
    }

    #[test]
    fn requests_are_made_seen_and_cleared() {
        let mut flash = MemFlash::new(10240);
        assert!(!requested(&flash, &LAYOUT));
        request_install(&mut flash, &LAYOUT).unwrap();
        assert!(requested(&flash, &LAYOUT));
        clear_request(&mut flash, &LAYOUT).unwrap();
        assert!(!requested(&flash, &LAYOUT));
    }
}
