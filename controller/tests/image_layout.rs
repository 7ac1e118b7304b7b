//! The checkpoint image as protocol/SPEC.md 3.5 describes it, written and checked here from
//! that description alone (LEB128 varints in the header, the values' order, a bitwise
//! CRC-32/ISO-HDLC over all but the last 4 bytes), against `checkpoint::save`, `verify` and
//! `restore`: another implementation that follows the text reads and writes the same bytes.

use trn_controller::checkpoint::{self, Provenance};
use trn_controller::presets::{Ablation, Preset};
use trn_controller::{Config, Controller, Error};

/// CRC-32/ISO-HDLC bit by bit (zlib's `crc32`): reflected polynomial 0xEDB88320, init and
/// xorout 0xFFFFFFFF.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// An unsigned LEB128 varint in its shortest form.
fn varint(out: &mut Vec<u8>, mut x: u32) {
    loop {
        let low = (x & 0x7F) as u8;
        x >>= 7;
        if x == 0 {
            out.push(low);
            return;
        }
        out.push(low | 0x80);
    }
}

/// Reads a varint at `*pos`.
fn read_varint(bytes: &[u8], pos: &mut usize) -> u32 {
    let (mut x, mut shift) = (0u32, 0);
    loop {
        let b = bytes[*pos];
        *pos += 1;
        x |= ((b & 0x7F) as u32) << shift;
        if b & 0x80 == 0 {
            return x;
        }
        shift += 7;
    }
}

/// The header's fields 2 to 9 of SPEC 3.5.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Header {
    version: u32,
    shapes: [u32; 6],
    t1: u32,
    t2: u32,
    preset: u8,
    ablation: u8,
    fingerprint: u32,
}

/// Every value of both networks in the image's order: stage 1 then stage 2, each its weights
/// `w[k][d]`, pressures `p[k][m]`, Jacobians `A[k][m][d]`.
fn values(c: &Controller) -> Vec<f32> {
    let mut v = Vec::new();
    let n1 = c.stage1().net();
    (0..1000).for_each(|k| v.extend(n1.weight(k)));
    (0..1000).for_each(|k| v.extend(n1.pressure(k)));
    (0..1000).for_each(|k| n1.jacobian(k).iter().for_each(|row| v.extend(row)));
    let n2 = c.stage2().net();
    (0..200).for_each(|k| v.extend(n2.weight(k)));
    (0..200).for_each(|k| v.extend(n2.pressure(k)));
    (0..200).for_each(|k| n2.jacobian(k).iter().for_each(|row| v.extend(row)));
    v
}

/// An image written from SPEC 3.5's table.
fn write_image(h: &Header, values: &[f32]) -> Vec<u8> {
    let mut out = b"TRNC".to_vec();
    varint(&mut out, h.version);
    h.shapes.iter().for_each(|&s| varint(&mut out, s));
    varint(&mut out, h.t1);
    varint(&mut out, h.t2);
    out.push(h.preset);
    out.push(h.ablation);
    varint(&mut out, h.fingerprint);
    values.iter().for_each(|x| out.extend(x.to_le_bytes()));
    let crc = crc32(&out);
    out.extend(crc.to_le_bytes());
    out
}

/// The header of an image read as SPEC 3.5 says, and where the values begin.
fn read_header(image: &[u8]) -> (Header, usize) {
    assert_eq!(&image[..4], b"TRNC");
    let mut pos = 4;
    let version = read_varint(image, &mut pos);
    let shapes = core::array::from_fn(|_| read_varint(image, &mut pos));
    let t1 = read_varint(image, &mut pos);
    let t2 = read_varint(image, &mut pos);
    let (preset, ablation) = (image[pos], image[pos + 1]);
    pos += 2;
    let fingerprint = read_varint(image, &mut pos);
    let h = Header {
        version,
        shapes,
        t1,
        t2,
        preset,
        ablation,
        fingerprint,
    };
    (h, pos)
}

fn seeded() -> Box<Controller> {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(11);
    c
}

fn saved(c: &Controller, provenance: Provenance) -> Vec<u8> {
    let mut buf = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(c, provenance, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

#[test]
fn the_crc_is_zlibs() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc32(b"123456789"), checkpoint::crc32(b"123456789"));
}

#[test]
fn an_image_is_laid_out_as_the_specification_says() {
    let c = seeded();
    let provenance = Provenance::of(Preset::Lifelong, Ablation::NoPriming);
    let image = saved(&c, provenance);
    let (h, values_at) = read_header(&image);
    assert_eq!(
        h,
        Header {
            version: 2,
            shapes: [1000, 8, 5, 200, 4, 3],
            t1: 0,
            t2: 0,
            preset: 2,
            ablation: 2,
            fingerprint: c.config().fingerprint(),
        }
    );
    // the bytes SPEC 3.5 gives for the version and the shapes
    assert_eq!(
        &image[4..13],
        &[0x02, 0xE8, 0x07, 0x08, 0x05, 0xC8, 0x01, 0x04, 0x03]
    );
    let header_len = values_at - 4;
    assert!((14..=24).contains(&header_len), "{header_len}");
    assert_eq!(image.len(), 4 + header_len + 227_200 + 4);
    assert_eq!(checkpoint::MAX_SIZE, 4 + 38 + 227_200 + 4);
    // the values in the order of the text, then the CRC of everything before it
    let spec = write_image(&h, &values(&c));
    assert_eq!(spec.len(), image.len());
    assert!(
        spec == image,
        "the image differs from the one SPEC 3.5 describes"
    );
    let n = image.len();
    let stored = u32::from_le_bytes(image[n - 4..].try_into().unwrap());
    assert_eq!(stored, crc32(&image[..n - 4]));
}

#[test]
fn an_image_written_from_the_specification_is_verified_and_restored() {
    let c = seeded();
    let (mut h, _) = read_header(&saved(&c, Provenance::CUSTOM));
    // learning steps of two and three varint bytes: the header grows, the image stays valid
    (h.t1, h.t2) = (300, 20_000);
    let image = write_image(&h, &values(&c));
    let got = checkpoint::verify(&image).unwrap();
    assert_eq!(
        (got.t1, got.t2, got.config_fingerprint),
        (300, 20_000, h.fingerprint)
    );
    assert_eq!(
        (got.provenance.preset, got.provenance.ablation),
        (0xFF, 0xFF)
    );
    let mut other = Box::new(Controller::new(Config::project_default()));
    checkpoint::restore(&mut other, &image).unwrap();
    assert_eq!(other.stage1().learning_step(), 300);
    assert_eq!(other.stage2().learning_step(), 20_000);
    // the restored controller writes the very same bytes back
    assert!(saved(&other, Provenance::CUSTOM) == image);
}

#[test]
fn the_checks_of_verify_come_in_the_order_the_specification_gives() {
    let c = seeded();
    let (h, _) = read_header(&saved(&c, Provenance::CUSTOM));
    let vals = values(&c);
    let with = |f: &dyn Fn(&mut Header)| {
        let mut h2 = h;
        f(&mut h2);
        write_image(&h2, &vals)
    };
    // a wrong version with a wrong CRC: the version is named first
    let mut image = with(&|h| h.version = 4);
    let n = image.len();
    image[n - 1] ^= 1;
    assert_eq!(
        checkpoint::verify(&image),
        Err(Error::CheckpointVersion { found: 4 })
    );
    // version 3 (compact) with f32 values: the values' length
    assert!(matches!(
        checkpoint::verify(&with(&|h| h.version = 3)),
        Err(Error::CheckpointLength { .. })
    ));
    assert_eq!(
        checkpoint::verify(&with(&|h| h.shapes[3] = 100)),
        Err(Error::CheckpointShape)
    );
    // a learning step beyond 100,000,000 with a valid CRC: contents
    assert_eq!(
        checkpoint::verify(&with(&|h| h.t1 = 100_000_001)),
        Err(Error::CheckpointContents)
    );
    assert!(checkpoint::verify(&with(&|h| h.t1 = 100_000_000)).is_ok());
    // one value byte flipped: the CRC
    let mut image = with(&|_| {});
    image[5000] ^= 0x10;
    assert!(matches!(
        checkpoint::verify(&image),
        Err(Error::CheckpointCrc { .. })
    ));
    // one value short, CRC recomputed: length
    let mut short = with(&|_| {});
    short.truncate(short.len() - 8);
    let crc = crc32(&short);
    short.extend(crc.to_le_bytes());
    assert!(matches!(
        checkpoint::verify(&short),
        Err(Error::CheckpointLength { .. })
    ));
}

/// One line of SPEC 3.5's image test vector: the text after `key:`.
fn spec_vector_line(key: &str) -> String {
    let spec = include_str!("../../protocol/SPEC.md");
    let from = spec
        .find("**Image test vector**")
        .expect("SPEC.md 3.5 has an image test vector");
    let block = &spec[from..];
    let start = block.find("```text\n").unwrap() + "```text\n".len();
    let end = start + block[start..].find("```").unwrap();
    block[start..end]
        .lines()
        .find_map(|l| l.strip_prefix(key).map(|v| v.trim().to_string()))
        .unwrap_or_else(|| panic!("the vector has no line {key}"))
}

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

#[test]
fn the_specifications_image_vector_is_what_the_code_verifies_restores_and_saves() {
    use trn_controller::presets::{configure, ImageSize};
    // the configuration the vector names: 3.2.1's (the project preset, no ablation, the TRN,
    // 1024 x 768 images), whose fingerprint is 0xF7F7B721
    let cfg = configure(Preset::Project, Ablation::None, ImageSize::DEFAULT);
    assert_eq!(cfg.fingerprint(), 0xF7F7_B721);
    let h = Header {
        version: 2,
        shapes: [1000, 8, 5, 200, 4, 3],
        t1: 300,
        t2: 20_000,
        preset: 0,
        ablation: 0,
        fingerprint: cfg.fingerprint(),
    };
    let vector: Vec<f32> = (0..56_800)
        .map(|i| ((i % 256) as f32 - 128.0) / 16.0)
        .collect();
    let image = write_image(&h, &vector);
    let (_, values_at) = read_header(&image);
    assert_eq!(
        image[..values_at],
        unhex(&spec_vector_line("header:"))[..],
        "fields 1 to 9"
    );
    assert_eq!(
        image[values_at..values_at + 32],
        unhex(&spec_vector_line("values:"))[..]
    );
    assert_eq!(
        image.len(),
        spec_vector_line("length:").parse::<usize>().unwrap()
    );
    let crc = u32::from_str_radix(spec_vector_line("crc:").trim_start_matches("0x"), 16).unwrap();
    let n = image.len();
    assert_eq!(u32::from_le_bytes(image[n - 4..].try_into().unwrap()), crc);
    assert_eq!(checkpoint::crc32(&image[..n - 4]), crc);
    // the code takes it as the text says, and writes the same bytes back
    let got = checkpoint::verify(&image).unwrap();
    assert_eq!(
        (got.t1, got.t2, got.config_fingerprint),
        (300, 20_000, 0xF7F7_B721)
    );
    let mut c = Box::new(Controller::new(cfg));
    if cfg!(feature = "compact") {
        // the compact build's i16 tables span a narrower range than the vector's values (-8 to
        // 7.94 in every entry): it refuses the image whole rather than clip it
        assert!(matches!(
            checkpoint::restore(&mut c, &image),
            Err(Error::CheckpointContents)
        ));
        return;
    }
    checkpoint::restore(&mut c, &image).unwrap();
    assert!(values(&c) == vector);
    assert!(saved(&c, Provenance::of(Preset::Project, Ablation::None)) == image);
}

/// A compact image (format version 3) as SPEC 3.5 says: format 2's header with version 3,
/// then each value as the i16 `round(x / step)` of its table's step (weights 2^-5,
/// pressures 2^-13, Jacobians 2^-18; ties to even, saturated), two bytes little endian, then
/// the CRC. Written from the text, it is the crate's `save_as(Compact)` byte for byte.
#[test]
fn a_compact_image_is_laid_out_as_the_specification_says() {
    use checkpoint::Encoding;
    let c = seeded();
    let mut buf = vec![0u8; Encoding::Compact.max_size()];
    let n = checkpoint::save_as(&c, Provenance::CUSTOM, Encoding::Compact, &mut buf).unwrap();
    let image = &buf[..n];
    let (h, values_at) = read_header(image);
    assert_eq!(h.version, 3);
    assert_eq!(image.len(), values_at + 113_600 + 4);
    let steps = [
        (8_000, 5),
        (5_000, 13),
        (40_000, 18),
        (800, 5),
        (600, 13),
        (2_400, 18),
    ];
    let mut spec = image[..values_at].to_vec();
    let mut at = 0;
    let vals = values(&c);
    for (count, bits) in steps {
        for x in &vals[at..at + count] {
            let q = (x * (1u32 << bits) as f32).round_ties_even();
            let q = q.clamp(i16::MIN as f32, i16::MAX as f32) as i16;
            spec.extend(q.to_le_bytes());
        }
        at += count;
    }
    assert_eq!(at, 56_800);
    spec.extend(crc32(&spec).to_le_bytes());
    assert!(spec == image, "the compact image differs from SPEC 3.5's");
    // and it restores to those steps
    let mut other = Box::new(Controller::new(Config::project_default()));
    checkpoint::restore(&mut other, image).unwrap();
    let w = other.stage1().net().weight(0)[0];
    assert_eq!(
        w,
        (c.stage1().net().weight(0)[0] * 32.0).round_ties_even() / 32.0
    );
}
