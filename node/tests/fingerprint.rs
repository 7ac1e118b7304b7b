//! The configuration fingerprint as protocol/SPEC.md 3.2.1 gives it, for an implementation
//! that reads no Rust: the spec's field order and encoding, written out here from the spec
//! (not with the controller's serializer), and a CRC-32 written from its definition, give
//! `Config::fingerprint` for every preset, ablation and law at several image sizes; the
//! spec's test vector (the project preset's bytes and fingerprint) is the code's, so the
//! spec and the code cannot drift apart.

use trn_controller::config::{Rate, StageConfig, TimeDecay};
use trn_controller::presets::{configure, Ablation, ImageSize, Preset, Profile};
use trn_controller::{Config, Law};

/// The bytes of SPEC.md 3.2.1: f32 little endian, u8 as is, u16 and u32 as varints, an
/// enum as the varint of its variant's index followed by its fields.
#[derive(Default)]
struct Bytes(Vec<u8>);

impl Bytes {
    fn f32(&mut self, x: f32) {
        self.0.extend(x.to_le_bytes());
    }
    fn u8(&mut self, x: u8) {
        self.0.push(x);
    }
    fn varint(&mut self, mut x: u32) {
        while x >= 0x80 {
            self.0.push(x as u8 | 0x80);
            x >>= 7;
        }
        self.0.push(x as u8);
    }
    fn rate(&mut self, r: &Rate) {
        self.f32(r.eps);
        match r.decay {
            TimeDecay::Exp { lambda } => {
                self.varint(0);
                self.f32(lambda);
            }
            TimeDecay::Sqrt { scale } => {
                self.varint(1);
                self.f32(scale);
            }
            TimeDecay::None => self.varint(2),
        }
        self.f32(r.floor);
    }
    fn stage(&mut self, s: &StageConfig) {
        self.f32(s.alpha_range);
        self.varint(s.fine_ranks.into());
        self.varint(s.coarse_ranks.into());
        self.f32(s.sigma);
        self.f32(s.sigma_start);
        self.f32(s.sigma_tau);
        self.rate(&s.w);
        self.rate(&s.p);
        self.rate(&s.j);
        let t = &s.tolerance;
        for x in [t.base, t.amplitude, t.tau, t.floor] {
            self.f32(x);
        }
        self.f32(s.mature_tolerance);
        self.u8(s.max_fine_moves);
        self.u8(s.min_fine_moves_learning);
        self.f32(s.min_dv);
        self.f32(s.dv_noise);
        self.f32(s.trial_secant);
        self.f32(s.map_step);
        self.f32(s.step_noise);
        for x in [
            s.pressure_limit,
            s.input_min,
            s.input_max,
            s.max_target_distance,
        ] {
            self.f32(x);
        }
        let i = &s.init;
        for x in [i.x.0, i.x.1, i.y.0, i.y.1, i.pressure, i.jacobian] {
            self.f32(x);
        }
    }
    fn config(c: &Config) -> Vec<u8> {
        Bytes::config_as(c, c.law.code())
    }
    /// The encoding with the law byte `law` (a host-side law's code included).
    fn config_as(c: &Config, law: u8) -> Vec<u8> {
        let mut b = Bytes::default();
        b.stage(&c.stage1);
        b.stage(&c.stage2);
        b.varint(c.supervised_steps);
        b.varint(u32::from(law));
        let r = &c.broyden;
        for x in [
            r.home,
            r.explore_step,
            r.damping,
            r.max_step,
            r.alpha,
            r.min_update_step,
        ] {
            b.f32(x);
        }
        b.u8(r.max_fine_moves);
        b.0
    }
}

/// CRC-32/ISO-HDLC bit by bit: reflected polynomial 0xEDB88320, init and xorout 0xFFFFFFFF.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &x in bytes {
        c ^= u32::from(x);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

const SIZES: [ImageSize; 3] = [
    ImageSize::DEFAULT,
    ImageSize {
        width: 640,
        height: 480,
    },
    ImageSize {
        width: 8192,
        height: 1,
    },
];

#[test]
fn the_specs_formula_gives_every_configurations_fingerprint() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926, "the CRC's check value");
    let mut seen = std::collections::BTreeSet::new();
    for &image in &SIZES {
        for &preset in Preset::ALL {
            for &ablation in Ablation::ALL {
                // every law code of the wire: the core's laws, and the host-side laws'
                // (their configuration the profile's with the TRN, fingerprinted with their
                // code)
                for code in 0..Law::WIRE_CODES {
                    let law = Law::decode(code).unwrap_or(Law::Trn);
                    let cfg = Profile {
                        preset,
                        ablation,
                        law,
                    }
                    .config(image);
                    let bytes = Bytes::config_as(&cfg, code);
                    let fp = cfg.fingerprint_as(code);
                    assert_eq!(
                        crc32(&bytes),
                        fp,
                        "{preset:?} {ablation:?} law {code} {image:?}: {}",
                        hex(&bytes)
                    );
                    if Law::decode(code).is_ok() {
                        assert_eq!(fp, cfg.fingerprint());
                    }
                    seen.insert(fp);
                }
            }
        }
    }
    // every constant counts: the configurations differ, and so do their fingerprints
    let n = SIZES.len() * Preset::ALL.len() * Ablation::ALL.len() * Law::WIRE_CODES as usize;
    assert!(seen.len() > n / 2, "{} fingerprints of {n}", seen.len());
}

/// The test vector of SPEC.md 3.2.1: the text block after the line `**Test vector**` (hex,
/// any layout) and the `0x` number after it.
fn spec_vector() -> (Vec<u8>, u32) {
    let spec = include_str!("../../protocol/SPEC.md");
    let at = spec
        .find("**Test vector**")
        .expect("SPEC.md has the test vector");
    let rest = &spec[at..];
    let open = rest.find("```text\n").expect("its bytes") + "```text\n".len();
    let close = open + rest[open..].find("```").unwrap();
    let digits: String = rest[open..close]
        .chars()
        .filter(|c| c.is_ascii_hexdigit())
        .collect();
    let bytes = (0..digits.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&digits[i..i + 2], 16).unwrap())
        .collect();
    let after = &rest[close..];
    let number = after.find("0x").expect("its fingerprint") + 2;
    let fp = u32::from_str_radix(&after[number..number + 8], 16)
        .expect("SPEC.md's fingerprint: 8 hex digits after 0x");
    (bytes, fp)
}

#[test]
fn the_specs_test_vector_is_the_project_presets() {
    let cfg = configure(Preset::Project, Ablation::None, ImageSize::DEFAULT);
    let (bytes, fp) = spec_vector();
    let ours = Bytes::config(&cfg);
    assert_eq!(
        hex(&bytes),
        hex(&ours),
        "SPEC.md's bytes are not the project preset's ({} bytes)",
        ours.len()
    );
    assert_eq!(
        crc32(&bytes),
        fp,
        "SPEC.md's fingerprint is not its bytes' CRC"
    );
    assert_eq!(
        fp,
        cfg.fingerprint(),
        "SPEC.md's fingerprint {fp:#010x} is not the code's {:#010x}",
        cfg.fingerprint()
    );
}
