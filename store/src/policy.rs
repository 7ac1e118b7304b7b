//! When to save: on entering `Mature` (the tables are final for the session), on a bus
//! command, and every N learning steps, with N derived from the part's flash endurance so
//! that the slots outlive the years of service asked of them.
//!
//! Each save erases every page of one slot once, and the two slots take turns, so a page
//! is erased once every two saves: a part rated for C erase cycles per page allows 2C saves,
//! of which this policy spends half (a derating for temperature and the rating's spread).

/// What the flash and the deployment allow and need.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Endurance {
    /// Rated erase cycles of a flash page (STM32H7: 10,000; STM32F4: 10,000; STM32G4:
    /// 10,000).
    pub erase_cycles: u32,
    /// Years of service the store must last.
    pub years: u32,
    /// Learning steps expected per day (one per learning trial and stage).
    pub steps_per_day: u32,
    /// Saves per day made for other reasons (entering `Mature`, bus commands).
    pub other_saves_per_day: u32,
}

/// Saves a part's pages allow over its service: two per erase cycle (the slots take turns),
/// derated by half.
pub const fn saves_allowed(erase_cycles: u32) -> u64 {
    erase_cycles as u64
}

/// The learning steps between two saves that keep the flash within its endurance over the
/// years asked: the steps of the whole service divided by the saves left once the other
/// saves are taken, rounded up; at least 1. `u32::MAX` (never save by steps) when the other
/// saves alone use up the endurance, or nothing is learned.
pub const fn steps_between_saves(e: &Endurance) -> u32 {
    let days = e.years as u64 * 366;
    let other = e.other_saves_per_day as u64 * days;
    let allowed = saves_allowed(e.erase_cycles);
    let steps = e.steps_per_day as u64 * days;
    if other >= allowed || steps == 0 {
        return u32::MAX;
    }
    let left = allowed - other;
    let every = steps.div_ceil(left);
    if every == 0 {
        1
    } else if every > u32::MAX as u64 {
        u32::MAX
    } else {
        every as u32
    }
}

/// Whether the tables should be saved now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SavePolicy {
    /// Learning steps between two saves ([`steps_between_saves`]); `u32::MAX`: never by steps.
    pub every_steps: u32,
}

impl SavePolicy {
    /// The policy for a part and a deployment.
    pub const fn for_endurance(e: &Endurance) -> SavePolicy {
        SavePolicy {
            every_steps: steps_between_saves(e),
        }
    }

    /// Whether `steps` learning steps (both stages) since the last save make one due.
    pub const fn due_by_steps(&self, steps_since_save: u32) -> bool {
        self.every_steps != u32::MAX && steps_since_save >= self.every_steps
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const H7: Endurance = Endurance {
        erase_cycles: 10_000,
        years: 10,
        steps_per_day: 5_000,
        other_saves_per_day: 1,
    };

    /// The example of the documentation: an STM32H7 (10,000 cycles) for ten years, 5,000
    /// learning steps and one other save a day.
    #[test]
    fn an_h7_for_ten_years() {
        let every = steps_between_saves(&H7);
        // 10 years x 366 days: 18,300,000 steps; 10,000 saves less 3,660 other ones
        assert_eq!(every, 18_300_000u64.div_ceil(10_000 - 3_660) as u32);
        assert_eq!(every, 2_887);
        // the pages' erases over the service stay within half the rating
        let saves = 18_300_000 / every as u64 + 3_660;
        assert!(saves / 2 <= 10_000 / 2, "{saves} saves");
    }

    /// More endurance or fewer years: saves more often; more steps a day: less often.
    #[test]
    fn the_interval_follows_the_budget() {
        let more = Endurance {
            erase_cycles: 100_000,
            ..H7
        };
        let longer = Endurance { years: 20, ..H7 };
        let busier = Endurance {
            steps_per_day: 50_000,
            ..H7
        };
        assert!(steps_between_saves(&more) < steps_between_saves(&H7));
        assert!(steps_between_saves(&longer) > steps_between_saves(&H7));
        assert!(steps_between_saves(&busier) > steps_between_saves(&H7));
    }

    #[test]
    fn other_saves_that_use_up_the_endurance_leave_none_by_steps() {
        let e = Endurance {
            other_saves_per_day: 3,
            ..H7
        };
        assert_eq!(steps_between_saves(&e), u32::MAX);
        let p = SavePolicy::for_endurance(&e);
        assert!(!p.due_by_steps(u32::MAX - 1));
        let idle = Endurance {
            steps_per_day: 0,
            ..H7
        };
        assert_eq!(steps_between_saves(&idle), u32::MAX);
        let p = SavePolicy::for_endurance(&H7);
        assert!(!p.due_by_steps(2_886) && p.due_by_steps(2_887));
    }
}
