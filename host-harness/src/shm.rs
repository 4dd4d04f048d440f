//! The host's end of the shared-memory link transport (see `kernel_logic::shm_link` for the
//! layout and the ring logic both ends share): the file behind the emulated target's link
//! device, mapped into `hil`, and the reader and writer [`crate::link::HostLink`] uses over it,
//! with the serial socket as the doorbell in both directions.
use std::io::{Read, Write};
use std::os::fd::AsRawFd;
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use kernel_logic::shm_link::{self, SharedMemory, HOST_TO_TARGET, TARGET_TO_HOST};

/// How long a write waits for the target to make room in its ring before it fails.
const WRITE_PATIENCE: Duration = Duration::from_secs(30);
/// What the host sends as a doorbell (the value means nothing).
const DOORBELL: u8 = 0;

/// The link device's backing file, mapped shared into this process.
pub struct MappedLink {
    base: *mut u8,
}

// SAFETY: the mapping is plain shared memory; every access goes through raw pointers (words as
// atomics), never through references, so threads (and QEMU on the other side) may use it at
// once.
unsafe impl Send for MappedLink {}
// SAFETY: as above.
unsafe impl Sync for MappedLink {}

impl MappedLink {
    /// Create `path` (replacing what was there) at the device's size and write a fresh header.
    pub fn create(path: &Path) -> std::io::Result<Self> {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)?;
        file.set_len(u64::from(shm_link::DEVICE_BYTES))?;
        let mut link = Self::map(&file)?;
        shm_link::initialise(&mut link);
        Ok(link)
    }

    /// Map an existing link file.
    pub fn open(path: &Path) -> std::io::Result<Self> {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)?;
        if file.metadata()?.len() < u64::from(shm_link::DEVICE_BYTES) {
            return Err(std::io::Error::other(format!(
                "{} is smaller than the link device",
                path.display()
            )));
        }
        let link = Self::map(&file)?;
        shm_link::check_header(&link)
            .map_err(|e| std::io::Error::other(format!("{}: {e:?}", path.display())))?;
        Ok(link)
    }

    fn map(file: &std::fs::File) -> std::io::Result<Self> {
        // SAFETY: a fresh shared mapping of DEVICE_BYTES of an open file at least that long;
        // the file may be closed afterwards (the mapping keeps it).
        let base = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                shm_link::DEVICE_BYTES as usize,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_SHARED,
                file.as_raw_fd(),
                0,
            )
        };
        if base == libc::MAP_FAILED {
            return Err(std::io::Error::last_os_error());
        }
        Ok(Self {
            base: base as *mut u8,
        })
    }

    fn word(&self, offset: usize) -> &AtomicU32 {
        assert!(offset.is_multiple_of(4) && offset + 4 <= shm_link::DEVICE_BYTES as usize);
        // SAFETY: in bounds and aligned (checked; the mapping is page-aligned); the word lives as
        // long as the mapping, which outlives `&self`. Only atomic operations touch it.
        unsafe { AtomicU32::from_ptr(self.base.add(offset) as *mut u32) }
    }

    fn check_range(offset: usize, len: usize) {
        assert!(offset + len <= shm_link::DEVICE_BYTES as usize);
    }
}

impl Drop for MappedLink {
    fn drop(&mut self) {
        // SAFETY: the mapping made in `map`, unmapped once.
        unsafe {
            libc::munmap(
                self.base as *mut libc::c_void,
                shm_link::DEVICE_BYTES as usize,
            );
        }
    }
}

impl SharedMemory for MappedLink {
    fn load_word(&self, offset: usize) -> u32 {
        u32::from_be(self.word(offset).load(Ordering::Acquire))
    }

    fn store_word(&mut self, offset: usize, value: u32) {
        self.word(offset).store(value.to_be(), Ordering::Release);
    }

    fn read_bytes(&self, offset: usize, out: &mut [u8]) {
        Self::check_range(offset, out.len());
        // SAFETY: in bounds (checked); the bytes are a ring's data the other side no longer
        // writes (the counts say so), copied without forming a reference to shared memory.
        unsafe { std::ptr::copy_nonoverlapping(self.base.add(offset), out.as_mut_ptr(), out.len()) }
    }

    fn write_bytes(&mut self, offset: usize, data: &[u8]) {
        Self::check_range(offset, data.len());
        // SAFETY: in bounds (checked); the other side does not read these bytes until the write
        // count that covers them is published.
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), self.base.add(offset), data.len()) }
    }
}

/// The mapping, shared by the reader thread and the writer (each changes its own ring's count).
type Shared = Arc<std::sync::Mutex<MappedLink>>;

/// Bytes from the target: its ring, read whenever the doorbell rings (or the socket's read
/// timeout passes, in case a doorbell raced).
pub struct ShmReader {
    link: Shared,
    doorbell: UnixStream,
}

/// Bytes to the target: into its ring (waiting while it is full), and a doorbell on flush.
pub struct ShmWriter {
    link: Shared,
    doorbell: UnixStream,
}

/// A reader and a writer over the link file `link` with the serial socket `doorbell` (whose
/// read timeout paces the reader).
pub fn open(link: &Path, doorbell: UnixStream) -> std::io::Result<(ShmReader, ShmWriter)> {
    let shared = Arc::new(std::sync::Mutex::new(MappedLink::open(link)?));
    Ok((
        ShmReader {
            link: shared.clone(),
            doorbell: doorbell.try_clone()?,
        },
        ShmWriter {
            link: shared,
            doorbell,
        },
    ))
}

fn ring_error(e: shm_link::RingError) -> std::io::Error {
    std::io::Error::other(format!("shared-memory link: {e:?}"))
}

impl Read for ShmReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        loop {
            let n = {
                let mut link = self.link.lock().unwrap();
                shm_link::consume(&mut *link, &TARGET_TO_HOST, buf).map_err(ring_error)?
            };
            if n > 0 {
                return Ok(n);
            }
            // Nothing yet: wait for the target's doorbell (its value means nothing).
            let mut bells = [0u8; 64];
            match self.doorbell.read(&mut bells)? {
                0 => return Ok(0),
                _ => continue,
            }
        }
    }
}

impl Write for ShmWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let deadline = Instant::now() + WRITE_PATIENCE;
        loop {
            let n = {
                let mut link = self.link.lock().unwrap();
                shm_link::produce(&mut *link, &HOST_TO_TARGET, buf).map_err(ring_error)?
            };
            if n > 0 || buf.is_empty() {
                return Ok(n);
            }
            // The target has not read what went before: ring (it may be asleep) and wait.
            self.doorbell.write_all(&[DOORBELL])?;
            if Instant::now() > deadline {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::TimedOut,
                    "the target did not read its shared-memory ring",
                ));
            }
            std::thread::sleep(Duration::from_micros(50));
        }
    }

    /// Ring the doorbell: what was written is whole frames the target may take now.
    fn flush(&mut self) -> std::io::Result<()> {
        self.doorbell.write_all(&[DOORBELL])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_written_into_the_file_come_out_of_the_other_ring_end_with_a_doorbell() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("link");
        let _created = MappedLink::create(&path).unwrap();
        let (host_end, target_end) = UnixStream::pair().unwrap();
        host_end
            .set_read_timeout(Some(Duration::from_millis(50)))
            .unwrap();
        let (mut reader, mut writer) = open(&path, host_end).unwrap();
        // Host to target: the frame lands in the host-to-target ring, the doorbell on the socket.
        writer.write_all(b"\x02hi\x00").unwrap();
        writer.flush().unwrap();
        let mut target = MappedLink::open(&path).unwrap();
        let mut got = [0u8; 8];
        let n = shm_link::consume(&mut target, &HOST_TO_TARGET, &mut got).unwrap();
        assert_eq!(&got[..n], b"\x02hi\x00");
        let mut bell = [0u8; 4];
        assert_eq!((&target_end).read(&mut bell).unwrap(), 1);
        // Target to host: written into the other ring, read after the target's doorbell.
        shm_link::produce(&mut target, &TARGET_TO_HOST, b"\x03ok\x00").unwrap();
        (&target_end).write_all(&[0]).unwrap();
        let mut out = [0u8; 8];
        let n = reader.read(&mut out).unwrap();
        assert_eq!(&out[..n], b"\x03ok\x00");
        // Nothing more: the read waits for a doorbell and times out.
        let e = reader.read(&mut out).unwrap_err();
        assert!(matches!(
            e.kind(),
            std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
        ));
    }
}
