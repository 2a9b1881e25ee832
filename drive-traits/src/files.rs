//! Reading the user's input files safely: only regular files (a fifo would block, a device
//! such as `/dev/zero` never ends), and text files only up to a size.

use std::io::Read as _;
use std::path::Path;

/// `Ok` when `path` is a regular file (links followed), an error saying what it is
/// otherwise (a directory, a fifo, a device, a socket); the error of `metadata` when it
/// cannot be read (missing, not allowed).
///
/// ```
/// use drive_traits::files::regular;
/// assert!(regular(std::path::Path::new("/dev/null")).unwrap_err().to_string().contains("not a regular file"));
/// assert!(regular(std::path::Path::new("/")).unwrap_err().to_string().contains("a directory"));
/// ```
pub fn regular(path: &Path) -> std::io::Result<()> {
    let meta = std::fs::metadata(path)?;
    if meta.is_file() {
        return Ok(());
    }
    let what = if meta.is_dir() {
        "a directory"
    } else {
        "not a regular file (a fifo, a device or a socket)"
    };
    Err(std::io::Error::new(
        std::io::ErrorKind::InvalidInput,
        format!("{what}, not a file to read"),
    ))
}

/// The text of the regular file `path`, refused beyond `max_bytes` (without reading more
/// than that).
///
/// ```
/// let dir = std::env::temp_dir().join("drive-files-doc");
/// std::fs::create_dir_all(&dir).unwrap();
/// let f = dir.join("a.toml");
/// std::fs::write(&f, "name = 'x'\n").unwrap();
/// assert_eq!(drive_traits::files::read_text(&f, 100).unwrap(), "name = 'x'\n");
/// assert!(drive_traits::files::read_text(&f, 4).unwrap_err().to_string().contains("more than 4 bytes"));
/// ```
pub fn read_text(path: &Path, max_bytes: u64) -> std::io::Result<String> {
    regular(path)?;
    let mut text = String::new();
    std::fs::File::open(path)?
        .take(max_bytes.saturating_add(1))
        .read_to_string(&mut text)?;
    if text.len() as u64 > max_bytes {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("more than {max_bytes} bytes: not a file of this kind"),
        ));
    }
    Ok(text)
}
