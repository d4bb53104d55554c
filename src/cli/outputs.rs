//! The output rules every subcommand follows, checked once before its work
//! from its parsed arguments: each output file can be written (its folder
//! exists and takes a file; it is not a folder, a socket, a link to
//! nothing), and the outputs of one command are distinct files, from each
//! other and from every file it reads (a flag whose value names an existing
//! file is an input), and no input or file output lies inside a folder
//! output that is replaced as a whole. A device or a named pipe is written
//! in place and may be named more than once (`/dev/null`).

use std::path::{Path, PathBuf};

/// Outputs that are folders (created, staged and swapped as a whole), by
/// subcommand path and argument id; every other argument named in
/// [`FILE_OUTPUTS`] is a file.
pub(super) const FOLDER_OUTPUTS: &[(&[&str], &str)] = &[
    (&["kernels"], "out_dir"),
    (&["study"], "out_dir"),
    (&["compare"], "out_dir"),
    (&["profiles", "compare"], "out_dir"),
    (&["engine"], "out_dir"),
];

/// Argument ids of output files.
pub(super) const FILE_OUTPUTS: &[&str] = &[
    "out",
    "csv",
    "mco",
    "plot",
    "view_profile",
    "irradiance_out",
    "preview",
];

/// The path of a file written beside an output, from the output's path.
type Derive = fn(&Path) -> PathBuf;

/// Files a subcommand writes beside an output argument, by subcommand path,
/// argument id and the derived path: the scene render's record.
const DERIVED_OUTPUTS: &[(&[&str], &str, Derive)] =
    &[(&["scene"], "out", |p| p.with_extension("json"))];

/// One argument's path, with the flag that gave it.
struct Named {
    flag: String,
    path: PathBuf,
}

/// What makes two paths the same file: the (device, inode) of an existing
/// file, else the canonical folder and the name of one to be created.
#[derive(PartialEq, Eq)]
enum Identity {
    Inode(u64, u64),
    Name(PathBuf),
}

fn identity(path: &Path) -> Option<Identity> {
    #[cfg(unix)]
    if let Ok(m) = std::fs::metadata(path) {
        use std::os::unix::fs::MetadataExt;
        return Some(Identity::Inode(m.dev(), m.ino()));
    }
    #[cfg(not(unix))]
    if let Ok(p) = path.canonicalize() {
        return Some(Identity::Name(p));
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(Identity::Name(
        dir.canonicalize().ok()?.join(path.file_name()?),
    ))
}

/// Checks every output of the running subcommand `path` (arguments `m`,
/// the subcommand's definition `command`) before the work.
pub(super) fn check(
    path: &[&str],
    command: &clap::Command,
    m: &clap::ArgMatches,
) -> anyhow::Result<()> {
    let (mut files, mut folders, mut inputs) = (Vec::new(), Vec::new(), Vec::new());
    for arg in command.get_arguments() {
        let id = arg.get_id().as_str();
        let flag = match (arg.get_long(), arg.get_value_names()) {
            (Some(l), _) => format!("--{l}"),
            (None, Some([v, ..])) => v.to_string(),
            (None, _) => id.to_uppercase(),
        };
        let values: Vec<PathBuf> = match m.try_get_many::<PathBuf>(id) {
            Ok(Some(v)) => v.cloned().collect(),
            // A string flag (`--material skin1`, `--material m.toml`) is an
            // input when it names an existing file.
            _ => match m.try_get_many::<String>(id) {
                Ok(Some(v)) => v.map(PathBuf::from).filter(|p| p.is_file()).collect(),
                _ => continue,
            },
        };
        let folder = FOLDER_OUTPUTS.iter().any(|(p, i)| *p == path && *i == id);
        for p in values {
            let named = Named {
                flag: flag.clone(),
                path: p,
            };
            if folder {
                folders.push(named);
            } else if FILE_OUTPUTS.contains(&id) {
                for (_, _, derive) in DERIVED_OUTPUTS
                    .iter()
                    .filter(|(p, i, _)| *p == path && *i == id)
                {
                    files.push(Named {
                        flag: format!("the record of {flag}"),
                        path: derive(&named.path),
                    });
                }
                ssskit::io::check_output_file(&named.path, &named.flag)?;
                files.push(named);
            } else {
                inputs.push(named);
            }
        }
    }
    distinct(&files, &inputs)?;
    outside_folders(&folders, &files, &inputs)
}

/// No two file outputs are one file, and no output is an input.
fn distinct(files: &[Named], inputs: &[Named]) -> anyhow::Result<()> {
    let ids: Vec<(&Named, Option<Identity>)> = files
        .iter()
        .filter(|f| !ssskit::io::writes_in_place(&f.path))
        .map(|f| (f, identity(&f.path)))
        .collect();
    for (i, (a, ia)) in ids.iter().enumerate() {
        let Some(ia) = ia else { continue };
        if let Some((b, _)) = ids[..i].iter().find(|(_, ib)| ib.as_ref() == Some(ia)) {
            anyhow::bail!(
                "{} and {} name the same file '{}': each output needs its own",
                b.flag,
                a.flag,
                a.path.display()
            );
        }
        if let Some(input) = inputs
            .iter()
            .find(|n| identity(&n.path).as_ref() == Some(ia))
        {
            anyhow::bail!(
                "{} '{}' is the file {} reads: an output never replaces an input, give another \
                 name",
                a.flag,
                a.path.display(),
                input.flag
            );
        }
    }
    Ok(())
}

/// No input and no file output lies inside a folder output (it is replaced
/// as a whole).
fn outside_folders(folders: &[Named], files: &[Named], inputs: &[Named]) -> anyhow::Result<()> {
    for dir in folders {
        let Ok(root) = dir.path.canonicalize() else {
            continue;
        };
        for n in files.iter().chain(inputs) {
            let inside = n
                .path
                .canonicalize()
                .ok()
                .or_else(|| {
                    identity(&n.path).and_then(|i| match i {
                        Identity::Name(p) => Some(p),
                        Identity::Inode(..) => None,
                    })
                })
                .is_some_and(|p| p.starts_with(&root));
            if inside {
                anyhow::bail!(
                    "{} '{}' lies inside {} '{}', which is replaced as a whole: give a file \
                     outside it",
                    n.flag,
                    n.path.display(),
                    dir.flag,
                    dir.path.display()
                );
            }
        }
    }
    Ok(())
}
