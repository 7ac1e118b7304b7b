//! Host-in-the-loop tests live in tests/tests/.
