//! Reading a named input file whole, with a bound on its size.
//!
//! Every file rockbench reads as input (a scene, a record, a suite manifest, a study, a gate
//! file, a trajectory, a checkpoint) is read whole. A path that names something without end,
//! such as `/dev/zero` or a pipe that never closes, would otherwise be read until memory runs
//! out; past [`MAX_BYTES`] it is refused instead, as an error of the read. Pipes and process
//! substitutions (`<(...)`) of an ordinary size are read as files are. The samples beside a
//! checkpoint, which grow with the run, are read to the count the checkpoint gives instead
//! (`native::checkpoint::SampleLog`).

use std::io::{self, Read};
use std::path::Path;

/// The largest input read: 2 GiB, some four times the trajectory of 5000 steps of an 860-block
/// wall (six columns a block), some ten thousand times a long earthquake record.
pub const MAX_BYTES: u64 = 2 << 30;

/// The bytes of `path`, at most [`MAX_BYTES`] of them.
pub fn read(path: &Path) -> io::Result<Vec<u8>> {
    read_at_most(path, MAX_BYTES)
}

/// The text of `path` (UTF-8), at most [`MAX_BYTES`] long.
pub fn read_to_string(path: &Path) -> io::Result<String> {
    String::from_utf8(read(path)?).map_err(|_| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            "stream did not contain valid UTF-8",
        )
    })
}

fn read_at_most(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let too_large = |why: &str| {
        io::Error::new(
            io::ErrorKind::FileTooLarge,
            format!(
                "more than {}: an input is read whole, and one this large is refused{why}",
                size(limit)
            ),
        )
    };
    let file = std::fs::File::open(path)?;
    // A regular file's length is known before it is read, and sizes the buffer once; a device
    // or a pipe reports 0 and is read up to one byte past the bound.
    let length = file.metadata().map(|m| m.len()).unwrap_or(0);
    if length > limit {
        return Err(too_large(&format!(" ({length} bytes)")));
    }
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(usize::try_from(length).unwrap_or(0).saturating_add(1))
        .map_err(|_| io::Error::from(io::ErrorKind::OutOfMemory))?;
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(
            " (a device such as /dev/zero, or a pipe that does not end?)",
        ));
    }
    Ok(bytes)
}

/// `bytes` in GiB where it is a whole number of them.
fn size(bytes: u64) -> String {
    const GIB: u64 = 1 << 30;
    if bytes >= GIB && bytes.is_multiple_of(GIB) {
        format!("{} GiB", bytes / GIB)
    } else {
        format!("{bytes} bytes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_within_the_bound_is_read_whole() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.csv");
        let text = "0,0\n0.01,1.5\n".repeat(1000);
        std::fs::write(&p, &text).unwrap();
        assert_eq!(read_to_string(&p).unwrap(), text);
        assert_eq!(
            read_at_most(&p, text.len() as u64).unwrap(),
            text.as_bytes()
        );
    }

    #[test]
    fn a_file_one_byte_past_the_bound_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.csv");
        std::fs::write(&p, "0123456789").unwrap();
        let e = read_at_most(&p, 9).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert!(e.to_string().starts_with("more than 9 bytes"), "{e}");
    }

    #[test]
    fn a_file_longer_than_the_bound_is_refused_before_it_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.csv");
        let f = std::fs::File::create(&p).unwrap();
        f.set_len(3 << 30).unwrap(); // sparse: no 3 GiB written
        let e = read(&p).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert!(
            e.to_string()
                .starts_with("more than 2 GiB: an input is read whole"),
            "{e}"
        );
        assert!(e.to_string().ends_with("(3221225472 bytes)"), "{e}");
    }

    #[test]
    fn a_device_without_end_is_refused_at_the_bound() {
        let e = read_at_most(Path::new("/dev/zero"), 1 << 20).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert!(e.to_string().contains("/dev/zero"), "{e}");
    }

    #[test]
    fn text_that_is_not_utf8_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.csv");
        std::fs::write(&p, [0x30, 0xff, 0x0a]).unwrap();
        assert_eq!(
            read_to_string(&p).unwrap_err().kind(),
            io::ErrorKind::InvalidData
        );
    }
}
