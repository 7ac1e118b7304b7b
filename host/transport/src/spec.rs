//! The bus forms of `--bus` ([`BusSpec`]) and what each one can do ([`BusProfile`], one
//! value per transport, as smoltcp's `DeviceCapabilities`): its clock and timing, whether
//! where the controller runs and whether its store can be a file. (Faults can be injected on
//! every bus: the in-process bus injects them itself, the host's port on the others.)
//! The lab reads the profile instead of matching on the transport.

use std::time::Duration;

use crate::error::TransportError;

/// A parsed `--bus` argument.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BusSpec {
    /// The in-process bus on a simulated clock, the controller node serviced inline.
    InProc,
    /// SocketCAN on an interface (vcan0 or a real adapter).
    SocketCan(String),
    /// SLCAN over the UART of the firmware in QEMU.
    SlcanQemu,
    /// SLCAN over a serial device (a USB-CAN adapter).
    SlcanSerial(String),
}

/// Where the controller of a run is and who starts it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerSite {
    /// In this process, serviced inline on the simulated clock.
    Inline,
    /// A `controller-node` process this run starts.
    Process,
    /// The firmware in QEMU, which this run starts.
    Qemu,
    /// A controller this run did not start (a board on the bus).
    External,
}

/// What one transport can do and how long its answers take.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusProfile {
    /// The runner waits this long for a sign of a trial (or an acknowledgement) before it
    /// repeats its request.
    pub reply: Duration,
    /// How often it repeats a request a live controller does not answer before it gives
    /// the trial up (or, for a mode or the session configuration, the run).
    pub retries: u32,
    /// The servo drives' heartbeat supervision: a controller silent this long is lost (the
    /// drives enter their safe state); heard within it, it is alive.
    pub heartbeat_timeout: Duration,
    /// The conformance suite's wait for an answer that must come.
    pub answer: Duration,
    /// The conformance suite's wait for what must not come (a quiet bus).
    pub quiet: Duration,
    /// A simulated clock (nothing waits in wall time) rather than the wall clock.
    pub simulated_clock: bool,
    /// The runner learns its reply timeout from the bus's round trips, `reply` its ceiling
    /// (a repeat then costs about a round trip, not `reply`); else it waits `reply`.
    pub adaptive_reply: bool,
    /// Where the controller runs.
    pub controller: ControllerSite,
    /// Its store can be a file of this run (`--tables`): the controller runs in this
    /// process or in a `controller-node` this run starts. (Checkpoints travel over every bus:
    /// the runner reads the tables out and writes them in, SPEC 3.5.)
    pub tables_file: bool,
    /// It can run a host-only law (the simulator's model, the oracle), which needs the
    /// plant in the same process.
    pub host_laws: bool,
}

impl BusSpec {
    /// Parses `inproc`, `socketcan:IFACE`, `slcan:qemu` or `slcan:/dev/DEVICE`.
    pub fn parse(s: &str) -> Result<BusSpec, TransportError> {
        match s {
            "inproc" => Ok(BusSpec::InProc),
            "slcan:qemu" => Ok(BusSpec::SlcanQemu),
            _ if s.starts_with("slcan:/") => {
                Ok(BusSpec::SlcanSerial(s["slcan:".len()..].to_string()))
            }
            _ => match s.strip_prefix("socketcan:") {
                Some(iface) if !iface.is_empty() => Ok(BusSpec::SocketCan(iface.to_string())),
                _ => Err(TransportError::open(
                    s,
                    "expected `inproc`, `socketcan:IFACE`, `slcan:qemu` or `slcan:/dev/DEVICE`",
                )),
            },
        }
    }

    /// The interface name used in candump logs.
    pub fn log_name(&self) -> &str {
        match self {
            BusSpec::SocketCan(iface) => iface,
            _ => "inproc0",
        }
    }

    /// What this bus can do; `external`: the controller runs elsewhere on it
    /// (`--external-controller`).
    pub fn profile(&self, external: bool) -> BusProfile {
        let site = |own| {
            if external {
                ControllerSite::External
            } else {
                own
            }
        };
        match self {
            // repeats cost no wall time here: a trial is given up only after 9 s of
            // simulated time without an answer (under 20 % loss a 7-segment message gets
            // through whole about one time in five)
            BusSpec::InProc => BusProfile {
                reply: Duration::from_millis(60),
                retries: 150,
                heartbeat_timeout: Duration::from_millis(500),
                answer: Duration::from_secs(10),
                quiet: Duration::from_millis(150),
                simulated_clock: true,
                // repeats cost no wall time, and the simulated time of every figure stays
                adaptive_reply: false,
                controller: ControllerSite::Inline,
                tables_file: true,
                host_laws: true,
            },
            // the firmware's clock runs about ten times slower than the wall clock under
            // QEMU's instruction counting: its 100 ms heartbeats arrive about every second
            // and its own repeats 200 ms of its time apart
            BusSpec::SlcanQemu => BusProfile {
                reply: Duration::from_secs(20),
                retries: 12,
                heartbeat_timeout: Duration::from_secs(30),
                answer: Duration::from_secs(120),
                quiet: Duration::from_secs(5),
                simulated_clock: false,
                // the emulated clock's pace varies with what the firmware computes, and its
                // UART's receive queue is short: the fixed timeout, well above any answer
                adaptive_reply: false,
                controller: site(ControllerSite::Qemu),
                tables_file: false,
                host_laws: false,
            },
            // a board behind SocketCAN or a serial adapter answers within milliseconds; the
            // serial line adds about 1 ms per frame at 115,200 baud
            BusSpec::SocketCan(_) | BusSpec::SlcanSerial(_) => BusProfile {
                reply: Duration::from_millis(300),
                retries: 12,
                heartbeat_timeout: Duration::from_millis(500),
                answer: Duration::from_secs(20),
                quiet: Duration::from_millis(600),
                simulated_clock: false,
                adaptive_reply: true,
                controller: match self {
                    BusSpec::SocketCan(_) => site(ControllerSite::Process),
                    _ => ControllerSite::External,
                },
                tables_file: !external && matches!(self, BusSpec::SocketCan(_)),
                host_laws: false,
            },
        }
    }
}

impl std::fmt::Display for BusSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BusSpec::InProc => write!(f, "inproc"),
            BusSpec::SocketCan(i) => write!(f, "socketcan:{i}"),
            BusSpec::SlcanQemu => write!(f, "slcan:qemu"),
            BusSpec::SlcanSerial(p) => write!(f, "slcan:{p}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bus_forms_parse_and_print_back() {
        for (s, spec) in [
            ("inproc", BusSpec::InProc),
            ("socketcan:vcan0", BusSpec::SocketCan("vcan0".into())),
            ("slcan:qemu", BusSpec::SlcanQemu),
            (
                "slcan:/dev/ttyACM0",
                BusSpec::SlcanSerial("/dev/ttyACM0".into()),
            ),
        ] {
            assert_eq!(BusSpec::parse(s).unwrap(), spec);
            assert_eq!(spec.to_string(), s);
        }
        for bad in ["", "socketcan:", "carrier-pigeon"] {
            let e = BusSpec::parse(bad).unwrap_err().to_string();
            assert!(e.contains("expected"), "{e}");
        }
    }

    #[test]
    fn only_the_in_process_bus_is_simulated_and_runs_host_laws() {
        for (spec, external) in [
            (BusSpec::SocketCan("vcan0".into()), false),
            (BusSpec::SocketCan("can0".into()), true),
            (BusSpec::SlcanQemu, false),
            (BusSpec::SlcanSerial("/dev/ttyACM0".into()), true),
        ] {
            let p = spec.profile(external);
            assert!(!p.simulated_clock && !p.host_laws, "{spec}");
            assert!(p.reply < p.answer && p.quiet < p.answer, "{spec}");
        }
        let p = BusSpec::InProc.profile(false);
        assert!(p.simulated_clock && p.host_laws && p.tables_file);
        // only the buses whose controller answers on the wall clock learn the round trip
        assert!(!p.adaptive_reply && !BusSpec::SlcanQemu.profile(false).adaptive_reply);
        assert!(BusSpec::SocketCan("x".into()).profile(false).adaptive_reply);
        assert!(
            BusSpec::SlcanSerial("/dev/x".into())
                .profile(true)
                .adaptive_reply
        );
        assert!(!BusSpec::SocketCan("x".into()).profile(true).tables_file);
        assert!(BusSpec::SocketCan("x".into()).profile(false).tables_file);
        assert!(!BusSpec::SlcanQemu.profile(false).tables_file);
        assert_eq!(
            BusSpec::SocketCan("x".into()).profile(true).controller,
            ControllerSite::External
        );
    }
}
