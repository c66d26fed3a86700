//! What a node keeps across restarts, and where a bootloader writes firmware.
//!
//! Both are traits so that a simulated node keeps them in memory or a file and
//! a board in its flash; RAM versions for tests and simulated nodes are here.

use motet_wire::service::{Version, UNPAIRED};
use serde::{Deserialize, Serialize};

/// A storage device refused or failed an operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StorageError {
    /// Outside the device.
    OutOfRange,
    /// The device failed (write error, worn block, file error).
    Device,
}

impl core::fmt::Display for StorageError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            StorageError::OutOfRange => f.write_str("outside the storage device"),
            StorageError::Device => f.write_str("storage device failed"),
        }
    }
}

/// What a node keeps across restarts. postcard-encodable (via
/// `motet_wire::encode`) for a simulated node's file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Persisted {
    /// The node's unique id, kept so that it survives restarts on a board whose chip has none.
    pub uid: u64,
    /// [`UNPAIRED`] until the node is paired.
    pub address: u16,
    /// Installed firmware.
    pub firmware: Version,
}

impl Persisted {
    /// A node that was never paired.
    pub const fn new(uid: u64, firmware: Version) -> Persisted {
        Persisted {
            uid,
            address: UNPAIRED,
            firmware,
        }
    }
}

/// Persistent record of a node's identity.
pub trait Store {
    /// The record saved last, if any.
    fn load(&mut self) -> Option<Persisted>;
    /// Replaces the record; on error the old one must still load.
    fn save(&mut self, p: &Persisted) -> Result<(), StorageError>;
}

/// Where the bootloader writes an uploaded firmware image. The installed
/// application is elsewhere (a second slot, or swapped in by the board when
/// the image is started), so a failed upload leaves it untouched.
pub trait Flash {
    /// Bytes available for an image.
    fn capacity(&self) -> u32;
    /// Writes `data` at `offset` (erasing underneath as the device needs).
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), StorageError>;
    /// Fills `buf` from `offset`.
    fn read(&self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError>;
}

/// A [`Store`] in memory.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RamStore {
    /// The record saved last, if any.
    pub record: Option<Persisted>,
    /// Saves made (a board counts flash wear).
    pub saves: u32,
}

impl Store for RamStore {
    fn load(&mut self) -> Option<Persisted> {
        self.record
    }
    fn save(&mut self, p: &Persisted) -> Result<(), StorageError> {
        self.record = Some(*p);
        self.saves += 1;
        Ok(())
    }
}

/// A [`Flash`] of `N` bytes in memory, erased to 0xFF like NOR flash.
#[derive(Clone, Debug)]
pub struct RamFlash<const N: usize> {
    bytes: [u8; N],
}

impl<const N: usize> Default for RamFlash<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> RamFlash<N> {
    /// Flash erased to 0xFF.
    pub const fn new() -> Self {
        RamFlash { bytes: [0xFF; N] }
    }
    /// The flash's contents.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }
    /// For tests and fault injection: the raw storage.
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.bytes
    }
    fn range(offset: u32, len: usize) -> Result<core::ops::Range<usize>, StorageError> {
        let start = offset as usize;
        match start.checked_add(len) {
            Some(end) if end <= N => Ok(start..end),
            _ => Err(StorageError::OutOfRange),
        }
    }
}

impl<const N: usize> Flash for RamFlash<N> {
    fn capacity(&self) -> u32 {
        u32::try_from(N).unwrap_or(u32::MAX)
    }
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), StorageError> {
        let r = Self::range(offset, data.len())?;
        self.bytes[r].copy_from_slice(data);
        Ok(())
    }
    fn read(&self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        let r = Self::range(offset, buf.len())?;
        buf.copy_from_slice(&self.bytes[r]);
        Ok(())
    }
}
