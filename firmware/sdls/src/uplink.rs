//! The secured task-network uplink: the byte string the host cuts into `UplinkChunk`s and the
//! target reassembles, verifies and only then validates and loads.
//!
//! ```text
//! offset  bytes  field (big-endian)
//! 0       2      SPI: the key that signed it
//! 2       4      anti-replay sequence number
//! 6       4      L: bytes of the task-network image
//! 10      L      the task-network image (autonomy::uplink's format)
//! 10+L    32     MAC: HMAC-SHA-256 over 0x01 and bytes 0..10+L
//! ```
//!
//! The length field makes a shortened transfer recognisable as such (`Truncated`) instead of
//! a MAC mismatch, and a transfer with bytes after the trailer as `BadLength`.
use fsw_bridge::security::MAC_LEN;
use fsw_bridge::{SecurityHeader, SecurityRefusal};

use crate::mac::{self, Service};
use crate::Key;

/// Bytes of the security header in front of the image.
pub const HEADER_LEN: usize = 10;
/// Bytes a secured uplink adds to its image.
pub const OVERHEAD: usize = HEADER_LEN + MAC_LEN;

/// A secured uplink split into its parts (nothing verified yet).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SecuredUplink<'a> {
    pub header: SecurityHeader,
    /// The task-network image.
    pub image: &'a [u8],
    /// Header and image: what the MAC covers after the service byte.
    pub covered: &'a [u8],
    pub mac: &'a [u8],
}

/// Split `bytes` into header, image and trailer: `Truncated` if they are shorter than the
/// header, the trailer and the length the header announces; `BadLength` if longer.
pub fn parse(bytes: &[u8]) -> Result<SecuredUplink<'_>, SecurityRefusal> {
    let (Some(spi), Some(sequence), Some(length)) =
        (bytes.get(0..2), bytes.get(2..6), bytes.get(6..HEADER_LEN))
    else {
        return Err(SecurityRefusal::Truncated);
    };
    let spi = u16::from_be_bytes([spi[0], spi[1]]);
    let sequence = u32::from_be_bytes([sequence[0], sequence[1], sequence[2], sequence[3]]);
    let length = u32::from_be_bytes([length[0], length[1], length[2], length[3]]);
    let Some(end) = usize::try_from(length)
        .ok()
        .and_then(|l| l.checked_add(OVERHEAD))
    else {
        return Err(SecurityRefusal::Truncated);
    };
    if bytes.len() < end {
        return Err(SecurityRefusal::Truncated);
    }
    if bytes.len() > end {
        return Err(SecurityRefusal::BadLength);
    }
    let image_end = end - MAC_LEN;
    Ok(SecuredUplink {
        header: SecurityHeader { spi, sequence },
        image: &bytes[HEADER_LEN..image_end],
        covered: &bytes[..image_end],
        mac: &bytes[image_end..],
    })
}

/// True iff the uplink's MAC is the one `key` gives (the SPI is the caller's to check).
pub fn verify_mac(key: &Key, uplink: &SecuredUplink<'_>) -> bool {
    mac::verify(
        &key.bytes,
        &[&[Service::Uplink as u8], uplink.covered],
        uplink.mac,
    )
}

/// `out` is too small for the secured uplink, or the image is longer than the length field
/// can say.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooLarge;

/// Write the secured uplink of `image` (signed with `key`, sequence number `sequence`) into
/// `out`; returns its length ([`OVERHEAD`] more than the image's).
pub fn sign_into(
    key: &Key,
    sequence: u32,
    image: &[u8],
    out: &mut [u8],
) -> Result<usize, TooLarge> {
    let length = u32::try_from(image.len()).map_err(|_| TooLarge)?;
    let end = image.len().checked_add(OVERHEAD).ok_or(TooLarge)?;
    let out = out.get_mut(..end).ok_or(TooLarge)?;
    out[0..2].copy_from_slice(&key.spi.to_be_bytes());
    out[2..6].copy_from_slice(&sequence.to_be_bytes());
    out[6..HEADER_LEN].copy_from_slice(&length.to_be_bytes());
    let image_end = HEADER_LEN + image.len();
    out[HEADER_LEN..image_end].copy_from_slice(image);
    let tag = mac::tag(&key.bytes, &[&[Service::Uplink as u8], &out[..image_end]]);
    out[image_end..].copy_from_slice(&tag);
    Ok(end)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEY: Key = Key {
        spi: 0x0102,
        bytes: [0x5a; 32],
    };

    fn signed(image: &[u8]) -> ([u8; 128], usize) {
        let mut out = [0u8; 128];
        let n = sign_into(&KEY, 0x0a0b0c0d, image, &mut out).unwrap();
        (out, n)
    }

    #[test]
    fn a_signed_uplink_parses_into_its_header_image_and_a_mac_that_verifies() {
        let (out, n) = signed(b"task network");
        assert_eq!(n, 12 + OVERHEAD);
        assert_eq!(
            &out[..HEADER_LEN],
            &[0x01, 0x02, 0x0a, 0x0b, 0x0c, 0x0d, 0, 0, 0, 12]
        );
        let parsed = parse(&out[..n]).unwrap();
        assert_eq!(
            parsed.header,
            SecurityHeader {
                spi: 0x0102,
                sequence: 0x0a0b0c0d
            }
        );
        assert_eq!(parsed.image, b"task network");
        assert!(verify_mac(&KEY, &parsed));
    }

    #[test]
    fn every_shortened_uplink_is_truncated_and_a_longer_one_has_a_bad_length() {
        let (out, n) = signed(b"task network");
        for len in 0..n {
            assert_eq!(parse(&out[..len]), Err(SecurityRefusal::Truncated), "{len}");
        }
        assert_eq!(parse(&out[..n + 1]), Err(SecurityRefusal::BadLength));
        // A length field that overflows is truncated, never a panic.
        let mut huge = [0xffu8; HEADER_LEN + MAC_LEN];
        huge[..2].copy_from_slice(&[0, 1]);
        assert_eq!(parse(&huge), Err(SecurityRefusal::Truncated));
    }

    #[test]
    fn any_changed_byte_or_another_key_fails_the_mac() {
        let (out, n) = signed(b"task network");
        for i in 0..n {
            for bit in [0x01, 0x80] {
                let mut forged = out;
                forged[i] ^= bit;
                // A changed length field makes it truncated or long: nothing to verify then.
                if let Ok(p) = parse(&forged[..n]) {
                    assert!(!verify_mac(&KEY, &p), "byte {i} bit {bit:#x}");
                }
            }
        }
        let other = Key {
            bytes: [0x5b; 32],
            ..KEY
        };
        assert!(!verify_mac(&other, &parse(&out[..n]).unwrap()));
    }

    #[test]
    fn signing_refuses_an_output_buffer_too_small() {
        let mut out = [0u8; OVERHEAD + 3];
        assert_eq!(sign_into(&KEY, 1, b"four", &mut out), Err(TooLarge));
        assert_eq!(sign_into(&KEY, 1, b"abc", &mut out), Ok(OVERHEAD + 3));
    }
}
