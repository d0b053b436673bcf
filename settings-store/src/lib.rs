//! The machine setup in flash: a [`sequential_storage`] map on any async [`NorFlash`].
//!
//! The firmware gives it the two 128 KiB sectors memory.x keeps free (see `firmware/src/settings.rs`);
//! the host tests give it a RAM flash that can lose power after any word write or erase.
//!
//! Key layout (one byte per key, the map keeps only the newest item of each key):
//!
//! | key | value |
//! |---|---|
//! | [`SETUP_KEY`] (4) | the setup as `Setup::to_blob` (format byte 5, `machine/src/setup/blob.rs` `FORMAT`: postcard through serde), checked by `Setup::from_blob` on load |
//! | 3 | retired: the setup in the hand-written encoding (format byte 2), left unread |
//! | [`BOOT_KEY`] (2) | boot counter, `u32` little endian (the link's boot id) |
//! | 1 | retired: the setup in its first (serde/postcard) encoding, left unread |
//!
//! A new, incompatible setup encoding must take a new key: an old blob under the old key then
//! simply reads as absent (defaults) instead of failing to decode.
//!
//! Power-cut safety comes from sequential-storage (CRC on every item, the newest complete item of a
//! key wins, half-written items and half-erased pages are repaired on the next operation); the
//! tests cut power at every write and erase of a save and check that loading afterwards gives
//! the old or the new setup.
//!
//! Flash writes stall code fetch on the single-bank F4 parts (a 128 KiB sector erase takes 1-2 s),
//! so a changed setup is saved only with the controller idle and the machine at rest: that rule
//! lives once, in the core's main loop (`gantry_machine::device::main_loop`, step 6 of
//! `MainLoop::pass`), which calls the firmware's `BoardPort::save_setup`.
#![no_std]

use core::ops::Range;
use embedded_storage_async::nor_flash::NorFlash;
use gantry_machine::setup::{Setup, SETUP_BLOB_MAX};
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage, SerializationError, Value};

/// Map key of the setup blob (1 and 3 held the retired encodings: a setup saved by older
/// firmware reads as absent, and the board starts with the defaults).
pub const SETUP_KEY: u8 = 4;
/// Map key of the boot counter.
pub const BOOT_KEY: u8 = 2;
/// Working buffer: the largest item (key + setup blob) rounded up to any flash word.
pub const DATA_BUFFER_LEN: usize = SETUP_BLOB_MAX + 32;

type NoCache = Cache<Uncached, Uncached, Uncached, u8>;

/// Every value of the map, one type for both keys: sequential-storage's map functions are
/// generic over the value type, and a second type (the boot counter's `u32`) doubled them in the
/// firmware's flash. The setup is stored borrowed and loaded owned (no second blob buffer).
///
/// A stored item says which it is by its length: the boot counter is exactly 4 bytes (little
/// endian, as sequential-storage stores a `u32`), a setup blob is always longer.
#[allow(clippy::large_enum_variant)] // lives on the stack for one load; no_std has no Box
enum Item<'s> {
    Store(&'s Setup),
    Loaded(Setup),
    Boots(u32),
}

impl<'a> Value<'a> for Item<'_> {
    fn serialize_into(&self, buffer: &mut [u8]) -> Result<usize, SerializationError> {
        let setup = match self {
            Item::Store(s) => *s,
            Item::Loaded(s) => s,
            Item::Boots(n) => {
                let out = buffer
                    .get_mut(..4)
                    .ok_or(SerializationError::BufferTooSmall)?;
                out.copy_from_slice(&n.to_le_bytes());
                return Ok(4);
            }
        };
        setup
            .to_blob(buffer)
            .map(|b| b.len())
            .ok_or(SerializationError::BufferTooSmall)
    }

    fn deserialize_from(buffer: &'a [u8]) -> Result<(Self, usize), SerializationError> {
        if let Ok(n) = <[u8; 4]>::try_from(buffer) {
            return Ok((Item::Boots(u32::from_le_bytes(n)), 4));
        }
        Setup::from_blob(buffer)
            .map(|s| (Item::Loaded(s), buffer.len()))
            .ok_or(SerializationError::InvalidFormat)
    }
}

/// True if `range` suits a store on `F` (page-aligned, at least two erase pages). Use it in a
/// const assertion, so a wrong range fails the build instead of panicking at boot.
pub const fn range_ok<F: NorFlash>(range: Range<u32>) -> bool {
    MapConfig::<F>::try_new(range).is_ok()
}

/// What [`SettingsStore::load`] found.
#[allow(clippy::large_enum_variant)] // returned once at boot; no_std has no Box
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Loaded {
    /// A valid stored setup.
    Stored(Setup),
    /// Nothing stored yet (a new board, or a setup format this firmware does not know by key).
    Absent,
    /// A stored item that does not decode as a valid setup (written by other firmware).
    Invalid,
    /// The flash failed or the store is beyond repair; the next save erases it.
    Failed,
}

impl Loaded {
    /// The setup to run with: the stored one, or the defaults.
    pub fn into_setup(self) -> Setup {
        match self {
            Loaded::Stored(s) => s,
            _ => Setup::default(),
        }
    }

    /// Short description for the boot log.
    pub fn describe(&self) -> &'static str {
        match self {
            Loaded::Stored(_) => "stored setup",
            Loaded::Absent => "no stored setup, defaults",
            Loaded::Invalid => "stored setup invalid, defaults",
            Loaded::Failed => "settings flash unreadable, defaults",
        }
    }
}

/// Why a save failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SaveError {
    /// The setup does not encode (larger than the blob limit).
    Encode,
    /// The flash reported an error (also after erasing the store once).
    Flash,
}

/// The setup store on a flash range of at least two erase pages.
pub struct SettingsStore<F: NorFlash> {
    map: MapStorage<u8, F, NoCache>,
    /// Set when the store reported corruption it could not repair: the next save erases first.
    needs_erase: bool,
}

/// Word-aligned working buffer (some flash drivers want aligned source data).
#[repr(C, align(8))]
pub struct DataBuffer(pub [u8; DATA_BUFFER_LEN]);

impl DataBuffer {
    pub const fn new() -> Self {
        DataBuffer([0; DATA_BUFFER_LEN])
    }
}

impl Default for DataBuffer {
    fn default() -> Self {
        Self::new()
    }
}

impl<F: NorFlash> SettingsStore<F> {
    /// A store on `range` (offsets as `flash` counts them). Panics unless the range is
    /// page-aligned and covers at least two erase pages.
    pub fn new(flash: F, range: Range<u32>) -> Self {
        SettingsStore {
            map: MapStorage::new(flash, MapConfig::new(range), Cache::new_uncached()),
            needs_erase: false,
        }
    }

    /// Gives the flash back.
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }

    /// Reads the stored setup.
    pub async fn load(&mut self, buf: &mut DataBuffer) -> Loaded {
        match self.map.fetch_item::<Item>(&mut buf.0, &SETUP_KEY).await {
            Ok(Some(Item::Loaded(s))) => Loaded::Stored(s),
            Ok(Some(Item::Store(_) | Item::Boots(_))) => Loaded::Invalid,
            Ok(None) => Loaded::Absent,
            Err(sequential_storage::Error::SerializationError(_)) => Loaded::Invalid,
            Err(_) => {
                self.needs_erase = true;
                Loaded::Failed
            }
        }
    }

    /// Stores `setup` (the newest item wins; the old one stays readable until it is complete).
    /// Stalls the CPU on single-bank flash: call only with the controller idle and the kernel
    /// drained (the core main loop's `BoardPort::save_setup` call).
    pub async fn save(&mut self, setup: &Setup, buf: &mut DataBuffer) -> Result<(), SaveError> {
        self.store(&SETUP_KEY, &Item::Store(setup), buf).await
    }

    /// Counts this power-up and returns the new count (1 on a fresh store): a boot id that differs
    /// at every power-up. A flash failure still returns a number (the count is then not kept).
    pub async fn next_boot_count(&mut self, buf: &mut DataBuffer) -> u32 {
        let last = match self.map.fetch_item::<Item>(&mut buf.0, &BOOT_KEY).await {
            Ok(Some(Item::Boots(n))) => n,
            _ => 0,
        };
        let next = last.wrapping_add(1);
        let _ = self.store(&BOOT_KEY, &Item::Boots(next), buf).await;
        next
    }

    async fn store(
        &mut self,
        key: &u8,
        value: &Item<'_>,
        buf: &mut DataBuffer,
    ) -> Result<(), SaveError> {
        if self.needs_erase {
            self.map.erase_all().await.map_err(|_| SaveError::Flash)?;
            self.needs_erase = false;
        }
        match self.map.store_item(&mut buf.0, key, value).await {
            Ok(()) => Ok(()),
            Err(sequential_storage::Error::SerializationError(_))
            | Err(sequential_storage::Error::ItemTooBig) => Err(SaveError::Encode),
            Err(sequential_storage::Error::Corrupted { .. }) => {
                // Beyond the crate's own repair: start the store afresh with this item.
                self.map.erase_all().await.map_err(|_| SaveError::Flash)?;
                self.map
                    .store_item(&mut buf.0, key, value)
                    .await
                    .map_err(|_| SaveError::Flash)
            }
            Err(_) => Err(SaveError::Flash),
        }
    }
}

#[cfg(test)]
mod tests;
