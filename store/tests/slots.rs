//! The two slots: which copy boots, damaged copies, copies this build refuses, staging an
//! incoming image, wear spread over both slots.

mod common;

use common::*;
use trn_controller::checkpoint::{self, Provenance};
use trn_controller::persist::{ApplyError, Expected, SaveError, StageError};
use trn_controller::{Controller, Error as CkptError};
use trn_store::slot::{Decoded, SlotHeader, HEADER_LEN};
use trn_store::{FlashStore, RestoreError, TableStore};

/// Flash offsets of the two slots of [`store`] (it starts one page in).
fn slot_at(slot: u32) -> usize {
    4096 + slot as usize * FlashStore::<Flash>::slot_size_needed() as usize
}

/// Which slot holds sequence `seq` (the first save goes to slot 0, then they alternate).
fn slot_of(seq: u32) -> u32 {
    (seq + 1) % 2
}

fn restored(
    s: &mut FlashStore<Flash>,
) -> (Box<Controller>, Result<trn_store::StoredCopy, RestoreError>) {
    let mut c = blank();
    let r = s.restore(&mut c, None);
    (c, r)
}

/// The flash of `s` after saving `old`, then `new` (sequence numbers 1 and 2).
fn two_copies(mut s: FlashStore<Flash>, old: &Controller, new: &Controller) -> Flash {
    save(&mut s, old).unwrap();
    save(&mut s, new).unwrap();
    s.into_flash()
}

#[test]
fn the_newest_copy_boots_and_saves_alternate_slots() {
    let (a, b, c) = (learned(1, 1), learned(2, 2), learned(3, 3));
    let mut s = store();
    assert_eq!(s.stored(), None);
    for (i, t) in [&a, &b, &c].into_iter().enumerate() {
        let copy = save(&mut s, t).unwrap();
        assert_eq!(copy.sequence, i as u32 + 1);
        assert_eq!(copy.steps.0, t.stage1().learning_step());
        assert_eq!(s.stored(), Some(copy));
    }
    let (got, r) = restored(&mut s);
    assert_eq!(r.unwrap().sequence, 3);
    assert!(same_tables(&got, &c));
    // three saves: slot 0 erased twice, slot 1 once, page by page
    let pages = FlashStore::<Flash>::slot_size_needed() as usize / 4096;
    let counts = s.flash().erase_counts();
    assert!(
        counts[1..1 + pages].iter().all(|&n| n == 2),
        "{:?}",
        &counts[..4]
    );
    assert!(counts[1 + pages..1 + 2 * pages].iter().all(|&n| n == 1));
    assert_eq!(counts[0], 0, "the page before the store is never touched");
}

#[test]
fn a_bit_flip_in_the_newest_copy_falls_back_to_the_previous_one() {
    let (old, new) = (learned(1, 2), learned(2, 3));
    for (what, at) in [("image", 5000usize), ("header", 9)] {
        let mut f = two_copies(store(), &old, &new);
        f.memory_mut()[slot_at(slot_of(2)) + at] ^= 0x04;
        let mut s = reboot(f);
        let (got, r) = restored(&mut s);
        assert_eq!(r.unwrap().sequence, 1, "{what}");
        assert!(same_tables(&got, &old), "{what}: the previous copy");
        // the next save goes into the damaged slot, never over the good copy
        // numbered above every valid header (a damaged header is no longer one)
        let newer = learned(3, 1);
        let seq = save(&mut s, &newer).unwrap().sequence;
        assert_eq!(seq, if what == "image" { 3 } else { 2 }, "{what}");
        let (got, _) = restored(&mut s);
        assert!(same_tables(&got, &newer));
        // it went into the damaged slot (the one sequence 2 had)
        let mut f = s.into_flash();
        f.memory_mut()[slot_at(slot_of(2)) + 7000] ^= 0x01;
        let (got, r) = restored(&mut reboot(f));
        assert_eq!(
            r.unwrap().sequence,
            1,
            "{what}: the copy kept through it all"
        );
        assert!(same_tables(&got, &old));
    }
}

#[test]
fn both_copies_damaged_is_a_typed_error_and_nothing_is_restored() {
    let mut s = store();
    save(&mut s, &learned(1, 1)).unwrap();
    save(&mut s, &learned(2, 1)).unwrap();
    let mut f = s.into_flash();
    f.memory_mut()[slot_at(0) + 100_000] ^= 0x80;
    f.memory_mut()[slot_at(1) + 3] ^= 0x80;
    let (got, r) = restored(&mut reboot(f));
    assert_eq!(r, Err(RestoreError::AllCorrupt));
    assert!(same_tables(&got, &blank()), "nothing restored");
}

#[test]
fn an_erased_flash_and_an_erased_store_hold_nothing() {
    let mut s = store();
    let (_, r) = restored(&mut s);
    assert_eq!(r, Err(RestoreError::NothingStored));
    save(&mut s, &learned(1, 1)).unwrap();
    save(&mut s, &learned(2, 1)).unwrap();
    s.erase().unwrap();
    assert_eq!(s.stored(), None);
    let (got, r) = restored(&mut s);
    assert_eq!(r, Err(RestoreError::NothingStored));
    assert!(same_tables(&got, &blank()));
    // and it starts again from sequence 1
    assert_eq!(save(&mut s, &learned(3, 1)).unwrap().sequence, 1);
}

/// Rewrites the header of the copy of sequence `seq` with `change` applied (a valid CRC).
fn rewrite_header(f: &mut Flash, seq: u32, change: impl Fn(&mut SlotHeader)) {
    let at = slot_at(slot_of(seq));
    let bytes: [u8; HEADER_LEN] = f.memory()[at..at + HEADER_LEN].try_into().unwrap();
    let Decoded::Valid(mut h) = SlotHeader::decode(&bytes) else {
        panic!("no header")
    };
    change(&mut h);
    f.memory_mut()[at..at + HEADER_LEN].copy_from_slice(&h.encode());
}

#[test]
fn a_copy_in_another_format_or_of_another_configuration_is_refused_not_replaced() {
    let (old, new) = (learned(1, 1), learned(2, 1));
    let mut s = store();
    save(&mut s, &old).unwrap();
    save(&mut s, &new).unwrap();
    let fp = new.config().fingerprint();
    let mut f = s.into_flash();
    // the newest written by a later build in its own format: refused, the older one not used
    let mut g = f.clone();
    rewrite_header(&mut g, 2, |h| h.format = 2);
    let (got, r) = restored(&mut reboot(g));
    assert_eq!(r, Err(RestoreError::Format { found: 2 }));
    assert!(same_tables(&got, &blank()));
    // tables of another configuration when this one is required
    let mut s = reboot(f.clone());
    let mut got = blank();
    assert_eq!(
        s.restore(&mut got, Some(fp ^ 1)),
        Err(RestoreError::Fingerprint {
            stored: fp,
            expected: fp ^ 1
        })
    );
    assert!(same_tables(&got, &blank()));
    assert!(s.restore(&mut got, Some(fp)).is_ok());
    // an intact image of another checkpoint version (its CRCs made right)
    let at = slot_at(slot_of(2)) + 64;
    let len = s.stored().unwrap().len as usize;
    f.memory_mut()[at + 4] = 9;
    let crc = checkpoint::crc32(&f.memory()[at..at + len - 4]);
    f.memory_mut()[at + len - 4..at + len].copy_from_slice(&crc.to_le_bytes());
    rewrite_header(&mut f, 2, |h| h.image_crc = crc);
    let (got, r) = restored(&mut reboot(f));
    assert_eq!(
        r,
        Err(RestoreError::Image(CkptError::CheckpointVersion {
            found: 9
        }))
    );
    assert!(same_tables(&got, &blank()));
}

fn image_of(c: &Controller) -> (Vec<u8>, Expected) {
    let mut image = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(c, Provenance::CUSTOM, &mut image).unwrap();
    image.truncate(n);
    let crc = u32::from_le_bytes(image[n - 4..].try_into().unwrap());
    let fingerprint = c.config().fingerprint();
    (image, Expected { crc, fingerprint })
}

fn stage(s: &mut FlashStore<Flash>, image: &[u8]) {
    s.stage_begin(image.len() as u32).unwrap();
    for (k, piece) in image.chunks(56).enumerate() {
        s.stage_write(k as u32 * 56, piece).unwrap();
    }
}

#[test]
fn a_staged_image_is_applied_only_whole_and_as_announced() {
    let (old, new) = (learned(1, 2), learned(2, 4));
    let (image, expected) = image_of(&new);
    let mut s = store();
    save(&mut s, &old).unwrap();
    // announced otherwise: refused, nothing applied, the stored copy unchanged
    for (bad, err) in [
        (
            Expected {
                crc: expected.crc ^ 1,
                ..expected
            },
            ApplyError::CrcMismatch,
        ),
        (
            Expected {
                fingerprint: expected.fingerprint ^ 1,
                ..expected
            },
            ApplyError::FingerprintMismatch,
        ),
    ] {
        stage(&mut s, &image);
        let mut into = old.clone();
        assert_eq!(s.stage_apply(&mut into, bad), Err(err));
        assert!(same_tables(&into, &old));
        assert_eq!(s.stored().unwrap().sequence, 1);
    }
    // incomplete, out of order, beyond the announced length
    s.stage_begin(image.len() as u32).unwrap();
    s.stage_write(0, &image[..56]).unwrap();
    assert_eq!(
        s.stage_write(112, &image[112..168]),
        Err(StageError::OutOfOrder)
    );
    assert_eq!(s.stage_write(0, &image[..56]), Err(StageError::OutOfOrder));
    let mut into = old.clone();
    assert_eq!(
        s.stage_apply(&mut into, expected),
        Err(ApplyError::Incomplete)
    );
    assert_eq!(
        s.stage_begin(checkpoint::MAX_SIZE as u32 + 1),
        Err(StageError::TooLarge)
    );
    s.stage_begin(100).unwrap();
    assert_eq!(s.stage_write(0, &[0u8; 101]), Err(StageError::TooLarge));
    // a damaged image with the right announcement: refused by the checkpoint's own checks
    let mut damaged = image.clone();
    damaged[3000] ^= 1;
    stage(&mut s, &damaged);
    assert!(matches!(
        s.stage_apply(&mut into, expected),
        Err(ApplyError::Image(CkptError::CheckpointCrc { .. }))
    ));
    assert!(same_tables(&into, &old));
    // whole and as announced: applied and stored as the newest copy, the old one kept
    stage(&mut s, &image);
    let copy = s.stage_apply(&mut into, expected).unwrap();
    assert_eq!(copy.sequence, 2);
    assert!(same_tables(&into, &new));
    let (got, _) = restored(&mut s);
    assert!(same_tables(&got, &new));
    let mut f = s.into_flash();
    f.memory_mut()[slot_at(slot_of(2)) + 64 + 10_000] ^= 2;
    let (got, _) = restored(&mut reboot(f));
    assert!(same_tables(&got, &old), "the previous copy is the backup");
}

#[test]
fn a_save_of_tables_that_learn_meanwhile_is_abandoned() {
    let mut t = learned(1, 2);
    let mut s = store();
    save(&mut s, &t).unwrap();
    s.save_begin(&t, Provenance::CUSTOM).unwrap();
    for _ in 0..80 {
        s.save_step(&t).unwrap();
    }
    assert!(s.saving());
    let v = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
    let mut cmd = t
        .begin(trn_controller::Task::Stage1 {
            v,
            supervised: None,
            learn: true,
        })
        .unwrap();
    while let trn_controller::Command::Move { .. } = cmd {
        cmd = t.observe(trn_controller::Observation::Lights(v)).unwrap();
    }
    assert_eq!(s.save_step(&t), Err(SaveError::Changed));
    assert!(!s.saving());
    assert_eq!(s.save_step(&t), Err(SaveError::NotStarted));
    assert_eq!(s.stored().unwrap().sequence, 1);
    let (got, _) = restored(&mut s);
    assert!(same_tables(&got, &learned(1, 2)));
}

#[test]
fn layouts_that_do_not_fit_are_refused() {
    use trn_store::LayoutError;
    let need = FlashStore::<Flash>::slot_size_needed();
    assert_eq!(
        FlashStore::new(Flash::new(200), 0, need - 4096).err(),
        Some(LayoutError::TooSmall { needed: need })
    );
    assert_eq!(
        FlashStore::new(Flash::new(200), 100, need).err(),
        Some(LayoutError::NotAligned)
    );
    assert_eq!(
        FlashStore::new(Flash::new(100), 0, need).err(),
        Some(LayoutError::OutOfBounds)
    );
}

/// A save cancelled while it erases (a trial began) and begun again keeps the pages it
/// erased: each page of its slot is erased once for the save. One cancelled after it began
/// programming erases again only the pages it programmed.
#[test]
fn a_cancelled_save_resumes_its_erases() {
    let t = learned(4, 2);
    let mut s = store();
    s.save_begin(&t, Provenance::CUSTOM).unwrap();
    let pages = s.erases_left() as usize;
    for _ in 0..pages / 2 {
        s.save_step(&t).unwrap();
    }
    s.save_cancel();
    assert!(!s.saving());
    s.save_begin(&t, Provenance::CUSTOM).unwrap();
    assert_eq!(s.erases_left() as usize, pages - pages / 2);
    // the rest of the erases, then two steps of programming, then a cancel
    for _ in 0..pages - pages / 2 + 2 {
        s.save_step(&t).unwrap();
    }
    s.save_cancel();
    s.save_begin(&t, Provenance::CUSTOM).unwrap();
    let again = s.erases_left();
    assert!(again >= 1 && (again as usize) < pages, "{again} of {pages}");
    let copy = loop {
        if let Some(c) = s.save_step(&t).unwrap() {
            break c;
        }
    };
    assert_eq!(copy.sequence, 1);
    let counts = s.flash().erase_counts();
    let erased: u32 = counts.iter().sum();
    assert_eq!(erased as usize, pages + again as usize, "{counts:?}");
    assert!(counts.iter().all(|&c| c <= 2));
    let (got, _) = restored(&mut s);
    assert!(same_tables(&got, &t));
}

/// With the erases in the background a save step never waits for one: on the H743's
/// timing a step that starts or polls an erase takes no time of the caller's, one that
/// programs takes its flash words' time; the save ends with each sector erased once.
#[test]
fn background_erases_take_no_time_of_a_step() {
    use trn_store::sim::{FlashTiming, H743Flash, SimClock};
    let t = learned(5, 1);
    let clock = SimClock::new();
    let slot = FlashStore::<H743Flash>::slot_size_needed();
    let flash = H743Flash::new(2 * slot as usize / 131072)
        .with_timing(clock.clone(), FlashTiming::H743_X32);
    let mut s = FlashStore::new(flash, 0, slot)
        .unwrap()
        .with_background_erase();
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
    // 4 KiB programmed: 128 flash words of 130 us
    assert_eq!(longest, 128 * 130, "the longest step (us)");
    assert_eq!(copy.sequence, 1);
    assert_eq!(s.flash().erase_counts(), &[1, 1, 0, 0]);
}

/// With ECC (the STM32H7's), a torn word is a fault to read: a slot whose header or image
/// holds one is no copy, the other slot's boots, the slot is reported, and the next save
/// goes into it and mends it.
#[test]
fn a_torn_word_with_ecc_is_a_damaged_copy_reported_and_mended_by_the_next_save() {
    let (old, new) = (learned(1, 2), learned(2, 3));
    for (what, at) in [("header", 0usize), ("image", 90_000)] {
        let mut f = two_copies(store_ecc(), &old, &new);
        f.tear_word((slot_at(slot_of(2)) + at) as u32);
        assert_eq!(f.torn_words(), 1);
        let mut s = reboot(f);
        let (got, r) = restored(&mut s);
        assert_eq!(r.unwrap().sequence, 1, "{what}: the previous copy");
        assert!(same_tables(&got, &old), "{what}");
        assert!(s.flash().ecc_faults() > 0, "{what}: the torn word was met");
        let reported = if what == "header" { 1 << slot_of(2) } else { 0 };
        assert_eq!(s.unreadable_slots(), reported, "{what}");
        let newer = learned(3, 1);
        save(&mut s, &newer).unwrap();
        assert_eq!(
            s.flash().torn_words(),
            0,
            "{what}: the save erased the torn word"
        );
        let (got, r) = restored(&mut s);
        r.unwrap();
        assert!(same_tables(&got, &newer), "{what}");
        assert_eq!(s.unreadable_slots(), 0);
    }
    // both headers torn: nothing restored (a typed error, not a flash error), a save works
    let mut f = two_copies(store_ecc(), &old, &new);
    f.tear_word(slot_at(0) as u32 + 32);
    f.tear_word(slot_at(1) as u32);
    let mut s = reboot(f);
    let (got, r) = restored(&mut s);
    assert_eq!(r, Err(RestoreError::AllCorrupt));
    assert!(same_tables(&got, &blank()));
    assert_eq!(s.unreadable_slots(), 0b11);
    save(&mut s, &new).unwrap();
    let (got, _) = restored(&mut s);
    assert!(same_tables(&got, &new));
}

#[test]
fn the_simulated_ecc_refuses_a_torn_word_until_its_page_is_erased() {
    use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
    use trn_store::sim::SimFlashError;
    let mut f = Flash::new(2).with_ecc();
    f.write(4096, &[0x5A; 64]).unwrap();
    f.tear_word(4096 + 32);
    let mut b = [0u8; 32];
    f.read(4096, &mut b).unwrap();
    assert_eq!(b, [0x5A; 32], "the whole word beside it reads");
    assert_eq!(f.read(4096 + 40, &mut b[..4]), Err(SimFlashError::Ecc));
    assert_eq!(
        f.read(4096 + 16, &mut b),
        Err(SimFlashError::Ecc),
        "a read across it"
    );
    assert_eq!(f.write(4096 + 32, &[0; 32]), Err(SimFlashError::NotErased));
    assert_eq!(f.ecc_faults(), 2);
    f.read(0, &mut b).unwrap();
    f.erase(4096, 8192).unwrap();
    f.read(4096 + 32, &mut b).unwrap();
    assert_eq!(b, [0xFF; 32]);
    // a program torn by a cut leaves its word torn
    f.cut_power_at(0);
    f.tear(true, 3);
    assert_eq!(f.write(4096, &[0; 32]), Err(SimFlashError::PowerLost));
    f.restore_power();
    assert_eq!(f.torn_words(), 1);
    assert_eq!(f.read(4096, &mut b), Err(SimFlashError::Ecc));
    // without ECC a torn word reads as whatever bits it holds
    let mut plain = Flash::new(1);
    plain.tear_word(0);
    plain.read(0, &mut b).unwrap();
}
