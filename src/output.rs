//! Output files of the CLI: checked before any GPU work (a missing folder, a directory where
//! a file is expected, a folder we cannot write, the wrong extension), and written under a
//! temporary name then renamed, so a failed or interrupted run leaves no half-written file
//! under the name the user asked for.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// Check that `path` can become a file with one of `exts` (lower case, without the dot):
/// its folder exists and is writable, and it is not itself a directory.
pub fn check_file(flag: &str, path: &Path, exts: &[&str]) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if !ext.as_deref().is_some_and(|e| exts.contains(&e)) {
        bail!(
            "{flag} {}: the file name must end in .{}",
            path.display(),
            exts.join(" or .")
        );
    }
    if path.is_dir() {
        bail!("{flag} {}: is a directory, not a file", path.display());
    }
    let folder = folder_of(path);
    if !folder.is_dir() {
        bail!(
            "{flag} {}: the folder {} does not exist",
            path.display(),
            folder.display()
        );
    }
    check_writable(flag, &folder)
}

/// Create the folder `dir` (and its parents) for numbered frames and check it is writable.
pub fn prepare_dir(flag: &str, dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!(
            "{flag} {}: is a file; --frames writes numbered PNGs into a folder",
            dir.display()
        );
    }
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{flag} {}: cannot create the folder", dir.display()))?;
    check_writable(flag, dir)
}

/// The temporary name `path` is written under before the rename.
pub fn partial(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    path.with_file_name(name)
}

/// Write `img` as a PNG to `path` through a temporary file and a rename.
pub fn save_png(img: &image::RgbaImage, path: &Path) -> Result<()> {
    let tmp = partial(path);
    let written = img
        .save_with_format(&tmp, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", path.display()));
    finish(written, &tmp, path)
}

/// After writing `tmp`: rename it to `path`, or remove it when the write failed.
pub fn finish<T>(written: Result<T>, tmp: &Path, path: &Path) -> Result<T> {
    match written {
        Ok(v) => {
            std::fs::rename(tmp, path).with_context(|| format!("writing {}", path.display()))?;
            Ok(v)
        }
        Err(e) => {
            let _ = std::fs::remove_file(tmp);
            Err(e)
        }
    }
}

fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Create and remove a probe file: the only portable test that a folder takes new files.
fn check_writable(flag: &str, folder: &Path) -> Result<()> {
    let probe = folder.join(format!(".kami-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .with_context(|| format!("{flag}: cannot write into the folder {}", folder.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}
