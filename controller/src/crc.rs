//! The CRC-32 (ISO-HDLC) every format of this crate ends with: checkpoints (whole or
//! streamed) and the configuration fingerprint. A leaf: it imports nothing of the crate.

/// The CRC-32/ISO-HDLC (a `static`: a streamed image keeps a running digest of it).
pub(crate) static CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC.checksum(bytes)
}
