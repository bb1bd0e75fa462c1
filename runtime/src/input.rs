//! Bounded input: the one gate every file the shading system and the renderer read passes.
//!
//! Before a file is read — by our own parsers or handed to `tobj`, `gltf`, `image` or `exr` —
//! [`check`] makes sure it is a regular file (not a device, a FIFO or a directory) no larger
//! than the limit of its [`FileKind`]; [`read`] and [`read_to_string`] then read it through a
//! reader that stops one byte past the limit, so a file that grows while it is read cannot
//! exhaust memory either. The limits are documented in `docs/limits.md` and each can be
//! raised for production assets by an environment variable ([`FileKind::env_var`]).
//!
//! This module owns file access only: it knows nothing of formats, networks or scenes.

use std::io::Read;
use std::path::{Path, PathBuf};

/// What a file holds, which decides its size limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// Our text formats: networks (.json), scenes (.toml), MaterialX documents, shader
    /// sources. Default limit 64 MiB.
    Text,
    /// Meshes: OBJ, glTF and their buffers. Default limit 2 GiB.
    Mesh,
    /// Images: textures and EXR files. Default limit 1 GiB.
    Image,
}

impl FileKind {
    /// The limit in bytes when no environment variable overrides it.
    pub const fn default_limit(self) -> u64 {
        match self {
            FileKind::Text => 64 << 20,
            FileKind::Mesh => 2 << 30,
            FileKind::Image => 1 << 30,
        }
    }

    /// The environment variable that overrides the limit (a byte count; `K`, `M` and `G`
    /// suffixes are powers of 1024).
    pub const fn env_var(self) -> &'static str {
        match self {
            FileKind::Text => "SHADENET_MAX_TEXT_BYTES",
            FileKind::Mesh => "SHADENET_MAX_MESH_BYTES",
            FileKind::Image => "SHADENET_MAX_IMAGE_BYTES",
        }
    }

    /// The kind's name in messages.
    pub const fn name(self) -> &'static str {
        match self {
            FileKind::Text => "text",
            FileKind::Mesh => "mesh",
            FileKind::Image => "image",
        }
    }

    /// The limit in force: the environment variable's value when it is set and valid, else
    /// [`FileKind::default_limit`].
    pub fn limit(self) -> Result<u64, InputError> {
        match std::env::var(self.env_var()) {
            Ok(v) => parse_bytes(&v).ok_or(InputError::BadLimit {
                var: self.env_var(),
                value: v,
            }),
            Err(_) => Ok(self.default_limit()),
        }
    }
}

/// Parses `123`, `64K`, `64M`, `2G` (powers of 1024); `None` for anything else or zero.
fn parse_bytes(s: &str) -> Option<u64> {
    let s = s.trim();
    let (digits, shift) = match s.as_bytes().last()? {
        b'k' | b'K' => (&s[..s.len() - 1], 10),
        b'm' | b'M' => (&s[..s.len() - 1], 20),
        b'g' | b'G' => (&s[..s.len() - 1], 30),
        _ => (s, 0),
    };
    let n: u64 = digits.parse().ok()?;
    let n = n.checked_mul(1u64 << shift)?;
    (n > 0).then_some(n)
}

/// A file that cannot be read as input.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The file is missing or unreadable.
    #[error("cannot read {role} {}", path.display())]
    Io {
        /// What the file is to the reader: `network`, `scene`, `texture`, `mesh`…
        role: &'static str,
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A device, a FIFO, a socket or a directory.
    #[error("{}: not a regular file ({what}); {kind} input must be a regular file", path.display())]
    NotRegular {
        /// The file.
        path: PathBuf,
        /// What it is instead.
        what: &'static str,
        /// The kind of input expected.
        kind: &'static str,
    },
    /// Larger than its kind's limit.
    #[error(
        "{}: {size} bytes is over the {limit}-byte limit for {kind} files (set {var} to raise it)",
        path.display()
    )]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size in bytes (at least; a growing file is stopped at `limit + 1`).
        size: u64,
        /// The limit in force.
        limit: u64,
        /// The kind of input.
        kind: &'static str,
        /// The variable that raises the limit.
        var: &'static str,
    },
    /// A text file that is not UTF-8.
    #[error("{}: not UTF-8 text (byte {offset})", path.display())]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// The first byte that is not valid UTF-8.
        offset: usize,
    },
    /// A limit variable that is not a positive byte count.
    #[error("{var}=`{value}`: expected a positive byte count such as 67108864, 64M or 2G")]
    BadLimit {
        /// The variable.
        var: &'static str,
        /// Its value.
        value: String,
    },
}

/// Checks that `path` is a regular file within its kind's limit; returns its size. `role`
/// says what the file is to the reader (`network`, `scene`, `texture`…) in messages.
pub fn check(path: &Path, kind: FileKind, role: &'static str) -> Result<u64, InputError> {
    check_within(path, kind, role, kind.limit()?)
}

/// [`check`] against a limit already looked up.
fn check_within(
    path: &Path,
    kind: FileKind,
    role: &'static str,
    limit: u64,
) -> Result<u64, InputError> {
    let meta = std::fs::metadata(path).map_err(|source| InputError::Io {
        role,
        path: path.to_path_buf(),
        source,
    })?;
    if !meta.is_file() {
        return Err(InputError::NotRegular {
            path: path.to_path_buf(),
            what: file_type_name(&meta),
            kind: kind.name(),
        });
    }
    too_large(path, kind, meta.len(), limit)?;
    Ok(meta.len())
}

fn too_large(path: &Path, kind: FileKind, size: u64, limit: u64) -> Result<(), InputError> {
    if size > limit {
        return Err(InputError::TooLarge {
            path: path.to_path_buf(),
            size,
            limit,
            kind: kind.name(),
            var: kind.env_var(),
        });
    }
    Ok(())
}

#[cfg(unix)]
fn file_type_name(meta: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a plain file"
    }
}

#[cfg(not(unix))]
fn file_type_name(meta: &std::fs::Metadata) -> &'static str {
    if meta.is_dir() {
        "a directory"
    } else {
        "not a plain file"
    }
}

/// Reads a whole file after [`check`], through a reader bounded at the limit.
pub fn read(path: &Path, kind: FileKind, role: &'static str) -> Result<Vec<u8>, InputError> {
    let limit = kind.limit()?;
    let size = check_within(path, kind, role, limit)?;
    let io = |source| InputError::Io {
        role,
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    // The size was checked above; the bound also stops a file that grows meanwhile.
    let mut bytes = Vec::with_capacity(size.min(limit) as usize);
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    too_large(path, kind, bytes.len() as u64, limit)?;
    Ok(bytes)
}

/// Reads a UTF-8 text file after [`check`], through a reader bounded at the limit.
pub fn read_to_string(
    path: &Path,
    kind: FileKind,
    role: &'static str,
) -> Result<String, InputError> {
    let bytes = read(path, kind, role)?;
    String::from_utf8(bytes).map_err(|e| InputError::NotUtf8 {
        path: path.to_path_buf(),
        offset: e.utf8_error().valid_up_to(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_parse() {
        assert_eq!(parse_bytes("123"), Some(123));
        assert_eq!(parse_bytes("64K"), Some(64 << 10));
        assert_eq!(parse_bytes("64m"), Some(64 << 20));
        assert_eq!(parse_bytes(" 2G "), Some(2 << 30));
        assert_eq!(parse_bytes("0"), None);
        assert_eq!(parse_bytes("-1"), None);
        assert_eq!(parse_bytes("M"), None);
        assert_eq!(parse_bytes("99999999999999G"), None);
    }

    #[test]
    fn missing_file_directory_and_device() {
        let e = read(Path::new("/nonexistent/x.json"), FileKind::Text, "network").unwrap_err();
        assert!(matches!(e, InputError::Io { .. }), "{e}");
        assert_eq!(e.to_string(), "cannot read network /nonexistent/x.json");
        let e = read(Path::new("/"), FileKind::Text, "network").unwrap_err();
        assert_eq!(
            e.to_string(),
            "/: not a regular file (a directory); text input must be a regular file"
        );
        #[cfg(unix)]
        {
            let e = read(Path::new("/dev/zero"), FileKind::Text, "network").unwrap_err();
            assert_eq!(
                e.to_string(),
                "/dev/zero: not a regular file (a character device); text input must be a regular file"
            );
        }
    }

    #[test]
    fn reads_within_the_limit_and_rejects_over_it() {
        let dir = std::env::temp_dir().join(format!("shadenet-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let small = dir.join("small.json");
        std::fs::write(&small, "{}").unwrap();
        assert_eq!(
            read_to_string(&small, FileKind::Text, "network").unwrap(),
            "{}"
        );
        // A sparse file just over the text limit: rejected from its size, nothing read.
        let big = dir.join("big.json");
        let f = std::fs::File::create(&big).unwrap();
        f.set_len(FileKind::Text.default_limit() + 1).unwrap();
        let e = check(&big, FileKind::Text, "network").unwrap_err();
        assert!(
            e.to_string().ends_with(
                "big.json: 67108865 bytes is over the 67108864-byte limit for text files (set SHADENET_MAX_TEXT_BYTES to raise it)"
            ),
            "{e}"
        );
        let bad = dir.join("bad.txt");
        std::fs::write(&bad, b"ab\xffc").unwrap();
        let e = read_to_string(&bad, FileKind::Text, "network").unwrap_err();
        assert!(
            e.to_string().ends_with("bad.txt: not UTF-8 text (byte 2)"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
