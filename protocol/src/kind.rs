//! The message kinds: the upper 7 bits of every CAN id, which are also its arbitration
//! priority (lower code wins), and whether a kind is a command or a report.
//!
//! Plain data below every other module (the crate's [`Error`](crate::Error) names a kind).
//! The table of kinds is here, once (`with_kinds!`); `id.rs` builds from it the checked
//! decoding of a code, and owns which node a kind allows.

macro_rules! kinds {
    ($($(#[$m:meta])* $name:ident = $code:expr, $cmd:expr;)*) => {
        /// The message kind: the upper 7 bits of the CAN id (lower = higher priority).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[repr(u8)]
        pub enum MessageKind {
            $($(#[$m])* $name = $code,)*
        }

        impl MessageKind {
            /// Every kind, in priority order.
            pub const ALL: &'static [MessageKind] = &[$(MessageKind::$name,)*];

            /// True for commands (node field = destination), false for reports
            /// (node field = source).
            pub const fn is_command(self) -> bool {
                match self {
                    $(MessageKind::$name => $cmd,)*
                }
            }
        }
    };
}

/// The table of every kind (name, code, command or report), handed to the macro `$then`:
/// `kinds!` here defines [`MessageKind`] from it, `id.rs` the checked decoding of a code.
macro_rules! with_kinds {
    ($then:ident) => {
        $then! {
            /// Emergency stop raised by any node (report).
            Emergency = 0x01, false;
            /// A node entered its safe state (report).
            SafeStateEntered = 0x02, false;
            /// Pressure command to one servo drive (command).
            PressureCommand = 0x08, true;
            /// Pressure and state feedback of one servo drive (report).
            ServoStatus = 0x09, false;
            /// Open/close the gripper (command).
            GripperCommand = 0x0A, true;
            /// Gripper state (report).
            GripperStatus = 0x0B, false;
            /// Ask the camera processor for an observation (command).
            CaptureRequest = 0x10, true;
            /// Camera observation (report).
            Observation = 0x11, false;
            /// Change the operating mode (command; node = controller or broadcast).
            ModeChange = 0x18, true;
            /// The session's run parameters (command; node = controller, or broadcast for the
            /// echo).
            SessionConfig = 0x19, true;
            /// A session configuration confirmed with a guard nonce (command to the controller).
            ConfirmedSessionConfig = 0x1A, true;
            /// Ask for a guard nonce (command to the controller).
            GuardRequest = 0x1B, true;
            /// A guard nonce (report by the controller).
            GuardNonce = 0x1C, false;
            /// Supervised pressure announcement for a priming trial (command to the controller).
            SupervisedPressure = 0x20, true;
            /// Stage-1 target (8-D lights) for a new trial (command to the controller).
            Stage1Target = 0x21, true;
            /// Stage-2 target (4-D centre) for a trial (command to the controller).
            Stage2Target = 0x22, true;
            /// Start a grasp trial (command to the controller).
            GraspRequest = 0x23, true;
            /// Result of a trial (report by the controller).
            TrialReport = 0x28, false;
            /// Error report (report).
            ErrorReport = 0x30, false;
            /// Status, save or erase of the stored tables (command to the controller).
            StoreCommand = 0x38, true;
            /// The tables and their stored copy (report by the controller).
            TablesStatus = 0x39, false;
            /// Start writing tables in (command to the controller).
            TableWriteBegin = 0x3A, true;
            /// Verify and apply the tables written in (command to the controller).
            TableWriteEnd = 0x3B, true;
            /// Heartbeat (report), `0x700 | node` as in CANopen.
            Heartbeat = 0x70, false;
            /// Ask for a chunk of the tables (command to the controller; bulk, below heartbeats).
            TableReadRequest = 0x78, true;
            /// A chunk of the tables (report by the controller; bulk).
            TableReadChunk = 0x79, false;
            /// A chunk of tables written in (command to the controller; bulk).
            TableWriteChunk = 0x7A, true;
            /// Chunks received so far (report by the controller; bulk).
            TableWriteAck = 0x7B, false;
        }
    };
}
pub(crate) use with_kinds;

with_kinds!(kinds);

impl MessageKind {
    /// The 7-bit code.
    pub const fn code(self) -> u8 {
        self as u8
    }
}
