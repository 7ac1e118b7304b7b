//! Controllers with distinct learned tables, a store on a simulated flash, and saving to
//! the end.
#![allow(dead_code)]

use trn_controller::checkpoint::Provenance;
use trn_controller::{Command, Config, Controller, Observation, Task};
use trn_store::sim::SimFlash;
use trn_store::{FlashStore, SaveError, StoredCopy, TableStore};

/// A flash like an STM32H7's in its write unit (32 bytes), with 4 KiB pages (more erase
/// steps than the H7's 128 KiB sectors, so more cut points).
pub type Flash = SimFlash<32, 4096>;

/// Tables seeded with `seed` that learned from `trials` stage-1 trials (a plant that lands
/// a few pixels off the target).
pub fn learned(seed: u64, trials: u32) -> Box<Controller> {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(seed);
    for t in 0..trials {
        let v = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0].map(|x| x + t as f32);
        let mut cmd = c
            .begin(Task::Stage1 {
                v,
                supervised: None,
                learn: true,
            })
            .unwrap();
        while let Command::Move { .. } = cmd {
            let mut seen = v;
            seen[0] += 3.0 + seed as f32 % 5.0;
            cmd = c.observe(Observation::Lights(seen)).unwrap();
        }
    }
    c
}

/// True when two controllers hold the same tables and learning steps.
pub fn same_tables(a: &Controller, b: &Controller) -> bool {
    a.stage1().net() == b.stage1().net()
        && a.stage2().net() == b.stage2().net()
        && a.stage1().learning_step() == b.stage1().learning_step()
        && a.stage2().learning_step() == b.stage2().learning_step()
}

/// A store over a fresh (erased) flash with room for its two slots and a page more.
pub fn store() -> FlashStore<Flash> {
    let slot = FlashStore::<Flash>::slot_size_needed();
    let pages = 2 * slot as usize / 4096 + 1;
    FlashStore::new(Flash::new(pages), 4096, slot).unwrap()
}

/// A store over a fresh flash with ECC (a torn word is an error to read, as on an STM32H7).
pub fn store_ecc() -> FlashStore<Flash> {
    reboot(store().into_flash().with_ecc())
}

/// The same store layout over `flash` (a reboot).
pub fn reboot(flash: Flash) -> FlashStore<Flash> {
    let slot = FlashStore::<Flash>::slot_size_needed();
    FlashStore::new(flash, 4096, slot).unwrap()
}

/// Saves `ctrl` to the end.
pub fn save<S: TableStore>(store: &mut S, ctrl: &Controller) -> Result<StoredCopy, SaveError> {
    store.save_begin(ctrl, Provenance::CUSTOM)?;
    loop {
        if let Some(copy) = store.save_step(ctrl)? {
            return Ok(copy);
        }
    }
}

/// A controller to restore into (other tables than any test saves).
pub fn blank() -> Box<Controller> {
    static BLANK: std::sync::OnceLock<Box<Controller>> = std::sync::OnceLock::new();
    BLANK.get_or_init(|| learned(999, 0)).clone()
}
