//! A store of compact images (checkpoint format 3, i16 values) on an STM32G474-shaped flash
//! (8-byte double words with ECC, 2 KiB pages): it fits beside the board's image where two
//! f32 slots do not, saves and restores the compact tables, stages only images that fit,
//! erases in the background, and survives power cuts with torn words.

mod common;

use common::*;
use trn_controller::checkpoint::{self, Encoding, Provenance};
use trn_controller::persist::{Expected, StageError};
use trn_controller::Controller;
use trn_store::sim::{FlashTiming, G474Flash, SimClock};
use trn_store::{FlashStore, TableStore};

/// The G474's second bank, where its store lives (the image runs from the first).
const BANK: u32 = 256 * 1024;

fn slot() -> u32 {
    FlashStore::<G474Flash>::slot_size_needed_as(Encoding::Compact)
}

/// A compact store over a fresh G474 flash of two slots, with ECC.
fn compact_store() -> FlashStore<G474Flash> {
    let pages = 2 * slot() as usize / 2048;
    compact_reboot(G474Flash::new(pages).with_ecc())
}

fn compact_reboot(flash: G474Flash) -> FlashStore<G474Flash> {
    FlashStore::new_as(flash, 0, slot(), Encoding::Compact).unwrap()
}

/// The compact image of `c`, as a store of compact images writes it.
fn compact_image(c: &Controller) -> Vec<u8> {
    let mut buf = vec![0u8; Encoding::Compact.max_size()];
    let n = checkpoint::save_as(c, Provenance::CUSTOM, Encoding::Compact, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// Two controllers hold the same compact tables: their compact images are alike (the
/// tables an f32 build restores from a compact image are the originals rounded to the
/// step).
fn same_compact_tables(a: &Controller, b: &Controller) -> bool {
    compact_image(a) == compact_image(b)
}

#[test]
fn two_compact_slots_fit_the_g474s_second_bank_and_two_f32_slots_do_not() {
    assert!(2 * slot() <= BANK, "two compact slots: {} B", 2 * slot());
    assert!(
        2 * FlashStore::<G474Flash>::slot_size_needed() > BANK,
        "two f32 slots would fit: the compact format is not needed"
    );
    assert_eq!(
        FlashStore::new(G474Flash::new(BANK as usize / 2048), 0, slot()).err(),
        Some(trn_store::LayoutError::TooSmall {
            needed: FlashStore::<G474Flash>::slot_size_needed()
        }),
        "a store of f32 images refuses a compact slot"
    );
}

/// A save writes the compact image (read back from the flash, byte for byte), each page of
/// the slot erased once, no step waiting for an erase (in the background, on the G474's
/// timing); the restore gives the compact tables.
#[test]
fn a_compact_store_saves_the_compact_image_and_restores_it() {
    let t = learned(5, 4);
    let clock = SimClock::new();
    let pages = 2 * slot() as usize / 2048;
    let flash = G474Flash::new(pages)
        .with_ecc()
        .with_timing(clock.clone(), FlashTiming::G474);
    let mut s = compact_reboot(flash).with_background_erase();
    assert_eq!(s.encoding(), Encoding::Compact);
    s.save_begin(&t, Provenance::CUSTOM).unwrap();
    let mut longest = 0;
    let copy = loop {
        let before = clock.now_us();
        let step = s.save_step(&t).unwrap();
        longest = longest.max(clock.now_us() - before);
        if let Some(c) = step {
            break c;
        }
        clock.advance(1_000);
    };
    let image = compact_image(&t);
    assert_eq!(copy.len as usize, image.len());
    // 4 KiB programmed a step: 512 double words of 85 us
    assert_eq!(longest, 512 * 85, "the longest step (us)");
    let used = (64 + image.len()).div_ceil(2048);
    let counts = s.flash().erase_counts();
    assert!(counts[..used].iter().all(|&n| n == 1), "{:?}", &counts[..4]);
    assert!(counts[slot() as usize / 2048..].iter().all(|&n| n == 0));
    let stored = &s.flash().memory()[64..64 + image.len()];
    assert!(
        stored == image.as_slice(),
        "the slot holds the compact image"
    );
    let mut got = blank();
    let r = s.restore(&mut got, None).unwrap();
    assert_eq!(r, copy);
    assert!(same_compact_tables(&got, &t));
    assert!(!same_compact_tables(&blank(), &t));
}

/// An image from the bus is staged as it came: a compact one applies, an f32 one (twice
/// the size) is refused before anything is written, and the stored copy stays.
#[test]
fn a_compact_store_stages_compact_images_and_refuses_f32_ones() {
    let (old, new) = (learned(1, 2), learned(2, 3));
    let mut s = compact_store();
    save(&mut s, &old).unwrap();
    let mut f32_image = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(&new, Provenance::CUSTOM, &mut f32_image).unwrap();
    assert_eq!(s.stage_begin(n as u32), Err(StageError::TooLarge));
    let image = compact_image(&new);
    s.stage_begin(image.len() as u32).unwrap();
    for (i, piece) in image.chunks(56).enumerate() {
        s.stage_write(i as u32 * 56, piece).unwrap();
    }
    let mut got = blank();
    let expected = Expected {
        crc: u32::from_le_bytes(image[image.len() - 4..].try_into().unwrap()),
        fingerprint: checkpoint::verify(&image).unwrap().config_fingerprint,
    };
    let copy = s.stage_apply(&mut got, expected).unwrap();
    assert_eq!(copy.sequence, 2);
    assert!(same_compact_tables(&got, &new));
    let mut again = blank();
    s.restore(&mut again, None).unwrap();
    assert!(same_compact_tables(&again, &new));
}

/// Power lost at cut points spread over a save (every 13th program or erase step: the
/// whole save is about 14,000), with ECC and torn words: every boot restores the previous
/// tables or the new ones.
#[test]
fn power_cuts_during_a_compact_save_boot_the_previous_or_the_new_tables() {
    let (old, new) = (learned(1, 3), learned(2, 5));
    let mut s = compact_store();
    save(&mut s, &old).unwrap();
    let flash = s.into_flash();
    let mut dry = flash.clone();
    dry.reset_steps();
    let mut dry = compact_reboot(dry);
    save(&mut dry, &new).unwrap();
    let steps = dry.flash().steps();
    let (mut tried, mut olds, mut news, mut faulted) = (0, 0, 0, 0);
    for k in (0..steps).step_by(13) {
        let mut f = flash.clone();
        f.cut_power_at(k);
        f.tear(true, k + 1);
        let mut s = compact_reboot(f);
        assert!(
            save(&mut s, &new).is_err(),
            "cut at {k}: the save completed"
        );
        let mut f = s.into_flash();
        f.restore_power();
        let faults = f.ecc_faults();
        let mut s = compact_reboot(f);
        let mut got = blank();
        let r = s.restore(&mut got, None);
        faulted += (s.flash().ecc_faults() > faults) as u32;
        match r {
            Ok(_) if same_compact_tables(&got, &old) => olds += 1,
            Ok(_) if same_compact_tables(&got, &new) => news += 1,
            other => panic!("cut at {k} of {steps}: {other:?}"),
        }
        tried += 1;
    }
    println!(
        "compact store, power cuts: {tried} of {steps} cut points tried; {olds} booted the previous tables, {news} the new ones, {faulted} met a torn word"
    );
    assert!(steps > 10_000, "{steps}");
    assert_eq!(olds + news, tried);
    assert!(
        olds > 0 && faulted > 0,
        "cuts before the commit, torn words met"
    );
}
