//! The protocol's code ranges of the `SessionConfig`'s enumerations are the controller's
//! enums: a preset, ablation or law added on one side and not on the other fails here.

use trn_controller::presets::{Ablation, Preset};
use trn_controller::Law;
use trn_protocol::{ABLATION_CODES, LAW_CODES, PRESET_CODES};

#[test]
fn the_protocols_code_ranges_are_the_controllers_enums() {
    assert_eq!(PRESET_CODES, Preset::COUNT);
    assert_eq!(ABLATION_CODES, Ablation::COUNT);
    assert_eq!(LAW_CODES, Law::COUNT);
    for code in 0..PRESET_CODES {
        assert_eq!(Preset::from_code(code).map(Preset::code), Some(code));
    }
    for code in 0..ABLATION_CODES {
        assert_eq!(Ablation::from_code(code).map(Ablation::code), Some(code));
    }
    for code in 0..LAW_CODES {
        assert_eq!(Law::from_code(code).map(Law::code), Some(code));
    }
}
