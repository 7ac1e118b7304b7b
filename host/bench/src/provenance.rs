//! What produced a report ([`Provenance`]): the version, the git commit of the sources and
//! whether they differed from it, the compiler and the main dependencies' locked versions
//! (read at build time by `build.rs`, so a binary carries them wherever it runs; `unknown`
//! when built from a tree without git), and the command line, the machine's name and the
//! time the report was made. The run's whole specification, plant configuration included, is the report's
//! `spec` beside it.

use serde::{Deserialize, Serialize};

/// Where a report came from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Provenance {
    /// The crate version of the tools (`trn-bench`).
    pub version: String,
    /// The git commit the build's sources came from (`unknown` without git).
    pub git_commit: String,
    /// Whether the build's sources differed from that commit (changed or new files);
    /// `None` when unknown.
    pub git_dirty: Option<bool>,
    /// The command line of the process that wrote the report (its arguments, the program
    /// first: `trn train --seed 3 ...`, or the Python interpreter's).
    pub command_line: Vec<String>,
    /// The compiler that built the tools (`rustc -V`; empty in reports made before it was
    /// recorded).
    #[serde(default)]
    pub rustc: String,
    /// The main dependencies as the build locked them (`nalgebra 0.33.2`, ...).
    #[serde(default)]
    pub dependencies: Vec<String>,
    /// The name of the machine that made the report (`unknown` when it has none to give).
    #[serde(default)]
    pub host: String,
    /// When the report was made: UTC, ISO 8601 to the second (`2026-12-05T09:52:23Z`).
    #[serde(default)]
    pub created_utc: String,
}

impl Provenance {
    /// This build's and this process's provenance.
    pub fn current() -> Provenance {
        Provenance {
            version: env!("CARGO_PKG_VERSION").to_string(),
            git_commit: env!("TRN_GIT_COMMIT").to_string(),
            git_dirty: match env!("TRN_GIT_DIRTY") {
                "true" => Some(true),
                "false" => Some(false),
                _ => None,
            },
            command_line: std::env::args_os()
                .map(|a| a.to_string_lossy().into_owned())
                .collect(),
            rustc: env!("TRN_RUSTC_VERSION").to_string(),
            dependencies: env!("TRN_DEPENDENCIES")
                .split(", ")
                .filter(|d| !d.is_empty())
                .map(str::to_string)
                .collect(),
            host: host_name(),
            created_utc: utc_now(),
        }
    }
}

/// The machine's name (Linux's `/proc/sys/kernel/hostname`, else `HOSTNAME`), `unknown`
/// without one.
fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// The time now, UTC, ISO 8601 to the second.
fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    iso8601(secs)
}

/// `secs` since 1970-01-01T00:00:00Z as `YYYY-MM-DDTHH:MM:SSZ` (the proleptic Gregorian
/// calendar: Howard Hinnant's days-to-civil).
fn iso8601(secs: u64) -> String {
    let (days, rem) = ((secs / 86_400) as i64, secs % 86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// A result file's content with its provenance beside it: `{"provenance": .., "results": ..}`.
#[derive(Debug, Clone, Serialize)]
pub struct Stamped<T> {
    /// Where it came from.
    pub provenance: Provenance,
    /// What it is.
    pub results: T,
}

impl<T> Stamped<T> {
    /// `results` with this process's provenance.
    pub fn new(results: T) -> Stamped<T> {
        Stamped {
            provenance: Provenance::current(),
            results,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fails if a date is off by a day at a month's, a leap year's or a century's edge.
    #[test]
    fn iso8601_dates_by_hand() {
        assert_eq!(iso8601(0), "1970-01-01T00:00:00Z");
        assert_eq!(iso8601(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(iso8601(951_868_799), "2000-02-29T23:59:59Z");
        assert_eq!(iso8601(4_107_542_400), "2100-03-01T00:00:00Z");
        assert_eq!(iso8601(1_796_463_143), "2026-12-05T09:32:23Z");
    }

    #[test]
    fn the_build_knows_its_commit_and_the_process_its_command_line() {
        let p = Provenance::current();
        assert_eq!(p.version, env!("CARGO_PKG_VERSION"));
        // this crate is built from the project's git checkout in development and CI
        if std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../.git")).exists() {
            assert_eq!(p.git_commit.len(), 40, "{}", p.git_commit);
            assert!(p.git_commit.chars().all(|c| c.is_ascii_hexdigit()));
            assert!(p.git_dirty.is_some());
        }
        assert!(!p.command_line.is_empty());
        assert!(p.rustc.starts_with("rustc 1."), "{}", p.rustc);
        for dep in ["nalgebra 0.33.", "postcard 1.", "serde 1."] {
            assert!(
                p.dependencies.iter().any(|d| d.starts_with(dep)),
                "{:?}",
                p.dependencies
            );
        }
        assert!(!p.host.is_empty());
        assert_eq!(p.created_utc.len(), 20, "{}", p.created_utc);
        // a report written before these fields were recorded still reads
        let old = r#"{"version":"0.1.0","git_commit":"x","git_dirty":null,"command_line":[]}"#;
        let p: Provenance = serde_json::from_str(old).unwrap();
        assert!(p.rustc.is_empty() && p.dependencies.is_empty());
        let json = serde_json::to_string(&Stamped::new(vec![1, 2])).unwrap();
        assert!(json.contains("\"git_commit\"") && json.contains("\"results\":[1,2]"));
    }
}
