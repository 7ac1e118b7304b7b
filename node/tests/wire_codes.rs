//! The protocol's code ranges of the `SessionConfig`'s enumerations are the controller's
//! enums: a preset, ablation or law added on one side and not on the other fails here.

use trn_controller::presets::{Ablation, Preset};
use trn_controller::Law;
use trn_protocol::{ABLATION_CODES, LAW_CODES, PRESET_CODES};

#[test]
fn the_protocols_code_ranges_are_the_controllers_enums() {
    assert_eq!(PRESET_CODES, Preset::COUNT);
    assert_eq!(ABLATION_CODES, Ablation::COUNT);
    assert_eq!(LAW_CODES, Law::WIRE_CODES);
    for code in 0..PRESET_CODES {
        assert_eq!(Preset::from_code(code).map(Preset::code), Some(code));
    }
    for code in 0..ABLATION_CODES {
        assert_eq!(Ablation::from_code(code).map(Ablation::code), Some(code));
    }
    for code in 0..Law::COUNT {
        assert_eq!(Law::decode(code).map(Law::code), Ok(code));
    }
    // the host-side laws' codes follow the core's: valid on the wire, unsupported here
    for (i, (code, _)) in Law::HOST_CODES.into_iter().enumerate() {
        assert_eq!(code, Law::COUNT + i as u8);
        assert_eq!(
            Law::decode(code),
            Err(trn_controller::Error::UnsupportedLaw)
        );
    }
}
