//! Reading an input file whole, with its size bounded before anything is allocated.
//!
//! Every file lcpbench reads comes from a user (problem files, scenes, meshes, recordings,
//! result tables), so it may be a device (`/dev/zero` never ends), a named pipe (opening one
//! blocks until a writer comes) or a directory. [`read_input_file`] refuses anything but a
//! regular file, refuses a file larger than the caller's limit from its metadata, and reads at
//! most that many bytes even if the file grows meanwhile.

use std::io::{Error, ErrorKind, Read};
use std::path::Path;

/// The bytes of the regular file `path`, at most `max_bytes` of them; the error says what is
/// wrong (not a regular file, larger than the limit, or the operating system's reason).
pub fn read_input_file(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    check_input_file(path, max_bytes)?;
    let file = std::fs::File::open(path)?;
    let mut bytes = Vec::new();
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64, max_bytes));
    }
    Ok(bytes)
}

/// Check that `path` is a regular file of at most `max_bytes` bytes (for a reader that streams
/// it); returns its size.
pub fn check_input_file(path: &Path, max_bytes: u64) -> std::io::Result<u64> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "it is {}, not a regular file (lcpbench reads inputs from regular files only)",
                file_kind(&meta)
            ),
        ));
    }
    if meta.len() > max_bytes {
        return Err(too_large(meta.len(), max_bytes));
    }
    Ok(meta.len())
}

fn too_large(size: u64, max_bytes: u64) -> Error {
    Error::new(
        ErrorKind::FileTooLarge,
        format!("the file has {size} bytes, beyond the limit of {max_bytes} bytes"),
    )
}

/// What a non-regular file is, for messages.
fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    if meta.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_fifo() {
            return "a named pipe";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "a special file"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files_within_the_limit_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.txt");
        std::fs::write(&file, "12345").unwrap();
        assert_eq!(read_input_file(&file, 5).unwrap(), b"12345");
        let e = read_input_file(&file, 4).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::FileTooLarge);
        assert!(e.to_string().contains("beyond the limit of 4 bytes"), "{e}");
        let e = read_input_file(dir.path(), 100).unwrap_err();
        assert!(e.to_string().contains("a directory"), "{e}");
        #[cfg(unix)]
        {
            let e = read_input_file(Path::new("/dev/zero"), 100).unwrap_err();
            assert!(e.to_string().contains("a device"), "{e}");
        }
    }
}
