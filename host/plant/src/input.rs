//! Opening an input file the tools read: only a regular file (or a symbolic link to one) is
//! opened, so a FIFO, a device or a socket given as an input is refused with a clear error
//! instead of blocking forever (a FIFO without a writer) or reading without end
//! (`/dev/zero`).

use std::fs::File;
use std::io;
use std::path::Path;

/// Why a path is not an input, in words: `None` for a regular file.
fn not_regular(meta: &std::fs::Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        None
    } else if t.is_dir() {
        Some("is a directory, not a file")
    } else {
        Some("is not a regular file (a FIFO, device or socket): inputs are files")
    }
}

/// Opens `path` for reading if it is a regular file; refuses anything else with an
/// [`io::ErrorKind::InvalidInput`] error that says what it is, before opening it (opening a
/// FIFO blocks until a writer comes).
pub fn open(path: &Path) -> io::Result<File> {
    if let Some(why) = not_regular(&std::fs::metadata(path)?) {
        return Err(io::Error::new(io::ErrorKind::InvalidInput, why));
    }
    let file = File::open(path)?;
    // what was opened, should the path have been replaced in between
    match not_regular(&file.metadata()?) {
        Some(why) => Err(io::Error::new(io::ErrorKind::InvalidInput, why)),
        None => Ok(file),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_regular_file_opens_and_a_device_or_directory_is_refused() {
        let dir = std::env::temp_dir().join(format!("trn-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("a.toml");
        std::fs::write(&f, b"x").unwrap();
        assert!(open(&f).is_ok());
        for p in [
            Path::new("/dev/zero"),
            Path::new("/dev/null"),
            dir.as_path(),
        ] {
            let e = open(p).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput, "{}", p.display());
        }
        assert_eq!(
            open(&dir.join("missing")).unwrap_err().kind(),
            io::ErrorKind::NotFound
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let dir = std::env::temp_dir().join(format!("trn-input-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("f.toml");
        let ok = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(ok.success());
        // without the check this open blocks forever (no writer)
        let e = open(&fifo).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        assert!(e.to_string().contains("FIFO"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
