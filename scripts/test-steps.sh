# Steps of the test suite beyond fmt, clippy and cargo test; sourced by scripts/test.sh.
# Each is a script of the project that installs what it needs.
