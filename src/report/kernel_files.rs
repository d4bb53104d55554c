//! The kernel files a job writes: each fitted kernel as JSON (read back)
//! with its HLSL, GLSL and WGSL arrays, under file names that must not
//! collide.

use crate::error::{Error, Result};
use crate::io::{file_stem, join_inside};
use crate::kernel::disk::DiskKernelFile;
use crate::kernel::emit::{emit, Lang};
use crate::kernel::KernelFile;
use crate::report::eval::compare::kernel::Comparison;
use std::path::Path;

/// File names made from labels (materials, models, images) in one
/// folder: each must be new, so that two labels that give one file name
/// (`a/b` and `a_b`) are refused rather than one overwriting the other.
#[derive(Default)]
pub(crate) struct FileNames(std::collections::BTreeMap<String, String>);

impl FileNames {
    pub(crate) fn claim(&mut self, name: String, label: &str) -> Result<String> {
        if let Some(other) = self.0.insert(name.clone(), label.to_string()) {
            return Err(Error::Unsupported(format!(
                "'{other}' and '{label}' give the same file name '{name}' (names become file \
                 names with every character but letters, digits, '-', '_', '+' and '.' \
                 replaced by '_'): rename one"
            )));
        }
        Ok(name)
    }
}

/// Every fitted kernel of the comparison as `dir/<material>-<label>.json`
/// (read back; both names through [`file_stem`]), with its HLSL, GLSL and
/// WGSL arrays next to it when `shaders`. `dir` is created. Returns the
/// file names written.
pub fn write_fitted_kernels(cmp: &Comparison, dir: &Path, shaders: bool) -> Result<Vec<String>> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::format(dir, format!("cannot create the kernel folder: {e}")))?;
    let mut names = FileNames::default();
    let mut files = Vec::new();
    for f in &cmp.fitted {
        let label = format!("{} {}", f.material, f.spec.label);
        let stem = names.claim(
            format!("{}-{}", file_stem(&f.material), file_stem(&f.spec.label)),
            &label,
        )?;
        write_kernel(&f.kernel, dir, &stem, shaders, &mut files)?;
    }
    Ok(files)
}

/// Writes a kernel file (read back) and, with `shaders`, its three shader
/// arrays next to it.
pub(crate) fn write_kernel(
    kernel: &KernelFile,
    dir: &Path,
    stem: &str,
    shaders: bool,
    files: &mut Vec<String>,
) -> Result<()> {
    write_read_back(dir, stem, files, |p| kernel.write(p), KernelFile::read)?;
    if !shaders {
        return Ok(());
    }
    write_shaders(dir, stem, files, |lang| emit(kernel, lang))
}

/// Writes `stem`.json with `write` and lists it once `read` has read it
/// back: a file its own reader refuses is an error, never an output.
fn write_read_back<T>(
    dir: &Path,
    stem: &str,
    files: &mut Vec<String>,
    write: impl FnOnce(&Path) -> Result<()>,
    read: impl FnOnce(&Path) -> Result<T>,
) -> Result<()> {
    let name = format!("{stem}.json");
    let path = join_inside(dir, &name)?;
    write(&path)?;
    read(&path)?;
    files.push(name);
    Ok(())
}

/// A kernel's shader arrays as `stem`.hlsl, .glsl and .wgsl.
fn write_shaders(
    dir: &Path,
    stem: &str,
    files: &mut Vec<String>,
    emit: impl Fn(Lang) -> Result<String>,
) -> Result<()> {
    for (lang, ext) in [
        (Lang::Hlsl, "hlsl"),
        (Lang::Glsl, "glsl"),
        (Lang::Wgsl, "wgsl"),
    ] {
        let name = format!("{stem}.{ext}");
        crate::io::write_atomic(&join_inside(dir, &name)?, emit(lang)?.as_bytes())?;
        files.push(name);
    }
    Ok(())
}

/// A disk kernel as `stem`.json with its shader arrays.
pub(crate) fn write_disk_kernel(
    kernel: &DiskKernelFile,
    dir: &Path,
    stem: &str,
    files: &mut Vec<String>,
) -> Result<()> {
    write_read_back(dir, stem, files, |p| kernel.write(p), DiskKernelFile::read)?;
    write_shaders(dir, stem, files, |lang| {
        crate::kernel::disk_emit::emit_disk(kernel, lang)
    })
}
