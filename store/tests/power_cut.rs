//! Power lost at every single program and erase step of a save (and of staging an incoming
//! image): after each cut the store boots with the previous tables or the new ones, never
//! torn ones, never none. With ECC (`SimFlash::with_ecc`, the STM32H7's semantics) a torn
//! word is an error to read rather than data: the store takes that slot for damaged and
//! boots the other copy.

mod common;

use common::*;
use trn_controller::checkpoint::{self, Provenance};
use trn_controller::persist::Expected;
use trn_controller::Controller;
use trn_store::{RestoreError, TableStore};

/// What a boot after a cut restored.
#[derive(Debug, Default)]
struct Outcomes {
    old: u32,
    new: u32,
    /// Boots whose restore met a torn word the flash refused to read (with ECC).
    faulted: u32,
}

/// A store as the operation under test uses it.
type Boot = fn(Flash) -> trn_store::FlashStore<Flash>;

/// Runs `op` on a store over a copy of `flash` with power lost at every step it makes, boots
/// after each cut, and checks the restored tables are `old` or `new`. Every `resave`-th cut
/// also saves `new` after the reboot and checks it is then restored. Returns how many cut
/// points were tried.
fn every_cut(
    boot: Boot,
    flash: &Flash,
    tear: bool,
    old: &Controller,
    new: &Controller,
    resave: u64,
    op: impl Fn(&mut trn_store::FlashStore<Flash>) -> bool,
) -> (u64, Outcomes) {
    // the steps of the whole operation, without a cut
    let mut f = flash.clone();
    f.reset_steps();
    let mut dry = boot(f);
    assert!(op(&mut dry), "the operation completes without a cut");
    let steps = dry.flash().steps();
    let mut out = Outcomes::default();
    for k in 0..steps {
        let mut f = flash.clone();
        f.cut_power_at(k);
        f.tear(tear, k + 1);
        let mut s = boot(f);
        assert!(
            !op(&mut s),
            "cut at step {k} of {steps}: the operation still completed"
        );
        let mut f = s.into_flash();
        assert!(f.power_lost());
        f.restore_power();
        let faults = f.ecc_faults();
        let mut s = reboot(f);
        let mut got = blank();
        let restored = s.restore(&mut got, None);
        out.faulted += (s.flash().ecc_faults() > faults) as u32;
        match restored {
            Ok(_) if same_tables(&got, old) => out.old += 1,
            Ok(_) if same_tables(&got, new) => out.new += 1,
            Ok(copy) => panic!("cut at step {k}: torn tables restored ({copy:?})"),
            Err(e) => panic!("cut at step {k}: nothing restored ({e:?})"),
        }
        if k % resave == 0 {
            save(&mut s, new).unwrap_or_else(|e| panic!("cut at {k}: save after it: {e:?}"));
            let mut again = blank();
            s.restore(&mut again, None).unwrap();
            assert!(same_tables(&again, new), "cut at {k}: the save after it");
            assert_eq!(
                s.unreadable_slots(),
                0,
                "cut at {k}: the save mended the flash"
            );
        }
    }
    (steps, out)
}

/// Runs `cuts` (boots that met an ECC fault) on a store without ECC: none.
fn no_fault(cuts: impl Fn(trn_store::FlashStore<Flash>) -> u32) {
    assert_eq!(cuts(store()), 0, "no ECC, no fault");
}

/// Runs `cuts` on a store with ECC: some cut left a torn word that a boot met.
fn faults_met(cuts: impl Fn(trn_store::FlashStore<Flash>) -> u32) {
    assert!(
        cuts(store_ecc()) > 0,
        "some cut left a torn word the boot met"
    );
}

/// Saves `ctrl`; false when the flash lost power.
fn saves(ctrl: &Controller) -> impl Fn(&mut trn_store::FlashStore<Flash>) -> bool + '_ {
    move |s| save(s, ctrl).is_ok()
}

#[test]
fn power_cut_at_every_step_of_the_first_save_after_one_copy() {
    let old = learned(1, 3);
    let new = learned(2, 5);
    let mut s = store();
    save(&mut s, &old).unwrap();
    let flash = s.into_flash();
    let (steps, out) = every_cut(reboot, &flash, false, &old, &new, 997, saves(&new));
    println!(
        "power_cut (one copy stored, clean cuts): {steps} cut points tried; {} booted the previous tables, {} the new ones",
        out.old, out.new
    );
    assert!(
        steps > 7_000,
        "{steps}: every program word and erased page is a cut point"
    );
    assert_eq!(
        out.old, steps as u32,
        "the new copy counts only once its header is whole"
    );
}

#[test]
fn power_cut_at_every_step_with_torn_words_and_pages_when_both_slots_hold_copies() {
    no_fault(|s| both_slots_hold_copies(s).faulted);
}

/// The same with ECC: each torn word a fault to read (the STM32H7), never data.
#[test]
fn power_cut_at_every_step_with_ecc_faults_when_both_slots_hold_copies() {
    faults_met(|s| both_slots_hold_copies(s).faulted);
}

/// A save into a store holding two copies, cut at every step with torn words and pages.
fn both_slots_hold_copies(mut s: trn_store::FlashStore<Flash>) -> Outcomes {
    let older = learned(3, 2);
    let old = learned(4, 4);
    let new = learned(5, 6);
    save(&mut s, &older).unwrap();
    save(&mut s, &old).unwrap();
    let flash = s.into_flash();
    let (steps, out) = every_cut(reboot, &flash, true, &old, &new, 997, saves(&new));
    println!(
        "power_cut (two copies stored, torn words and pages): {steps} cut points tried; {} booted the previous tables, {} the new ones, {} boots met an ECC fault",
        out.old, out.new, out.faulted
    );
    assert!(steps > 7_000);
    assert_eq!(out.old + out.new, steps as u32);
    out
}

/// Staging an incoming image and applying it, cut at every step: the previous tables or the
/// new ones.
#[test]
fn power_cut_at_every_step_of_staging_and_applying_an_image() {
    no_fault(|s| staging(s).faulted);
}

/// The same with ECC.
#[test]
fn power_cut_at_every_step_of_staging_with_ecc_faults() {
    faults_met(|s| staging(s).faulted);
}

/// Stages and applies an image into a store holding one copy, cut at every step (torn).
fn staging(mut s: trn_store::FlashStore<Flash>) -> Outcomes {
    let old = learned(6, 3);
    let new = learned(7, 2);
    save(&mut s, &old).unwrap();
    let flash = s.into_flash();
    let mut image = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(&new, Provenance::CUSTOM, &mut image).unwrap();
    image.truncate(n);
    let expected = Expected {
        crc: u32::from_le_bytes(image[n - 4..].try_into().unwrap()),
        fingerprint: new.config().fingerprint(),
    };
    let stage = |s: &mut trn_store::FlashStore<Flash>| {
        if s.stage_begin(image.len() as u32).is_err() {
            return false;
        }
        for (k, piece) in image.chunks(56).enumerate() {
            if s.stage_write(k as u32 * 56, piece).is_err() {
                return false;
            }
        }
        let mut into = blank();
        s.stage_apply(&mut into, expected).is_ok()
    };
    let (steps, out) = every_cut(reboot, &flash, true, &old, &new, 1_999, stage);
    println!(
        "power_cut (staging an incoming image, torn): {steps} cut points tried; {} booted the previous tables, {} the new ones, {} boots met an ECC fault",
        out.old, out.new, out.faulted
    );
    assert!(steps > 7_000);
    out
}

/// Erasing the stored copies, cut at every step: the copy or nothing, never torn tables.
#[test]
fn power_cut_while_erasing_leaves_the_copy_or_nothing() {
    no_fault(erase_cut_at_every_step);
}

/// The same with ECC: a header or page left torn by the cut is refused, never read.
#[test]
fn power_cut_while_erasing_with_ecc_faults_leaves_the_copy_or_nothing() {
    faults_met(erase_cut_at_every_step);
}

/// Erases a store holding one copy with power lost at each step, boots after each cut:
/// the copy or nothing. Returns the boots that met an ECC fault.
fn erase_cut_at_every_step(mut s: trn_store::FlashStore<Flash>) -> u32 {
    let old = learned(8, 2);
    save(&mut s, &old).unwrap();
    let flash = s.into_flash();
    let mut f = flash.clone();
    f.reset_steps();
    let mut dry = reboot(f);
    dry.erase().unwrap();
    let steps = dry.flash().steps();
    let mut faulted = 0;
    for k in 0..steps {
        let mut f = flash.clone();
        f.cut_power_at(k);
        f.tear(true, k + 7);
        let mut s = reboot(f);
        assert!(s.erase().is_err());
        let mut f = s.into_flash();
        f.restore_power();
        let mut got = blank();
        let faults = f.ecc_faults();
        let mut s = reboot(f);
        let restored = s.restore(&mut got, None);
        faulted += (s.flash().ecc_faults() > faults) as u32;
        match restored {
            Ok(_) => assert!(same_tables(&got, &old), "cut {k}: torn tables"),
            Err(RestoreError::NothingStored | RestoreError::AllCorrupt) => {
                assert!(
                    same_tables(&got, &blank()),
                    "cut {k}: a refused copy was used"
                )
            }
            Err(e) => panic!("cut {k}: {e:?}"),
        }
    }
    println!(
        "power_cut (erasing the copies, torn): {steps} cut points tried, {faulted} boots met an ECC fault"
    );
    faulted
}

/// A save on a flash that erases in the background, cancelled halfway through its erases (a
/// trial began) and resumed, cut at every step: the previous tables or the new ones.
#[test]
fn power_cut_at_every_step_of_a_resumed_save_with_background_erases() {
    no_fault(|s| resumed_save(s).faulted);
}

/// The same with ECC.
#[test]
fn power_cut_at_every_step_of_a_resumed_save_with_ecc_faults() {
    faults_met(|s| resumed_save(s).faulted);
}

/// A save cancelled and resumed (background erases) into a store holding one copy, cut at
/// every step with torn words and pages.
fn resumed_save(mut s: trn_store::FlashStore<Flash>) -> Outcomes {
    let old = learned(8, 3);
    let new = learned(9, 4);
    save(&mut s, &old).unwrap();
    let flash = s.into_flash();
    let resumed = |s: &mut trn_store::FlashStore<Flash>| {
        let mut run = || -> Result<(), trn_store::SaveError> {
            s.save_begin(&new, Provenance::CUSTOM)?;
            for _ in 0..20 {
                s.save_step(&new)?;
            }
            s.save_cancel();
            s.save_begin(&new, Provenance::CUSTOM)?;
            while s.save_step(&new)?.is_none() {}
            Ok(())
        };
        run().is_ok()
    };
    let boot: Boot = |f| reboot(f).with_background_erase();
    let (steps, out) = every_cut(boot, &flash, true, &old, &new, 997, resumed);
    println!(
        "power_cut (a resumed save, background erases, torn words and pages): {steps} cut points tried; {} booted the previous tables, {} the new ones, {} boots met an ECC fault",
        out.old, out.new, out.faulted
    );
    assert!(steps > 7_000);
    assert_eq!(out.old + out.new, steps as u32);
    out
}
