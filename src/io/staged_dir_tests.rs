//! A signal at the dangerous moments of a folder swap, made deterministic:
//! the commit pauses at a hook (`hooks::Point`) while a thread runs the
//! signal thread's clean-up (`remove_registered`, limited to this test's
//! folder, since other tests of the process register temporaries too) and
//! records the files as the process would leave them when the clean-up
//! ends it.

use super::hooks::{Point, NO_EXCHANGE, ON};
use super::*;
use crate::io::temps::{long_hold, remove_registered};
use std::sync::mpsc::{channel, Receiver};
use std::time::Duration;

/// How long a paused side gives the other before going on: fixed, the
/// other side waits for the lock the paused one holds, so the whole pause
/// passes; unfixed, the other side acts within microseconds of it.
const PAUSE: Duration = Duration::from_millis(400);
/// A side that should answer at once, given all the time a loaded machine
/// may need.
const PATIENCE: Duration = Duration::from_secs(60);

/// Every file under `root`, relative, sorted, with its content.
fn tree(root: &Path) -> Vec<(String, String)> {
    fn walk(root: &Path, d: &Path, out: &mut Vec<(String, String)>) {
        for e in std::fs::read_dir(d).into_iter().flatten().flatten() {
            let p = e.path();
            let name = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
            if p.is_dir() {
                out.push((name + "/", String::new()));
                walk(root, &p, out);
            } else {
                out.push((name, std::fs::read_to_string(&p).unwrap_or_default()));
            }
        }
    }
    let mut out = Vec::new();
    walk(root, root, &mut out);
    out.sort();
    out
}

/// A run of `files` staged for `out`, not committed.
fn run(out: &Path, files: &[(&str, &str)]) -> StagedDir {
    let s = StagedDir::new(out).unwrap();
    for (name, text) in files {
        write_atomic(&s.path().join(name), text.as_bytes()).unwrap();
    }
    s
}

/// The clean-up of the signal thread for the temporaries under `root`, in
/// a thread of its own; `after_first` runs after its first removal, the
/// lock held. Sends the tree of `root` as the process leaves it.
fn cleanup(
    root: PathBuf,
    after_first: impl Fn() + Send + 'static,
) -> Receiver<Vec<(String, String)>> {
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let mut held = live_temps();
        let first = std::cell::Cell::new(true);
        remove_registered(&mut held, |p| p.starts_with(&root), &|_| {
            if first.replace(false) {
                after_first();
            }
        });
        tx.send(tree(&root)).unwrap();
    });
    rx
}

fn with_hook<T>(hook: impl Fn(Point) + 'static, body: impl FnOnce() -> T) -> T {
    ON.with(|h| *h.borrow_mut() = Some(Box::new(hook)));
    let r = body();
    ON.with(|h| *h.borrow_mut() = None);
    r
}

const OLD: &[(&str, &str)] = &[("a.txt", "old")];
const NEW: &[(&str, &str)] = &[("b1.txt", "new"), ("b2.txt", "new"), ("b3.txt", "new")];

/// A temporary folder (its guard and path) whose `run` holds the committed
/// OLD run, with the NEW run staged to replace it.
fn old_committed_new_staged() -> (tempfile::TempDir, PathBuf, StagedDir) {
    let (dir, out) = crate::io::scratch("run");
    run(&out, OLD).commit().unwrap();
    let staged = run(&out, NEW);
    let root = dir.path().to_path_buf();
    (dir, root, staged)
}

/// The tree of a folder `run` holding `files` and the marker, alone in
/// its parent.
fn only(files: &[(&str, &str)]) -> Vec<(String, String)> {
    let marker = std::str::from_utf8(
        b"ssskit output folder: the next run writing here replaces it as a whole\n",
    )
    .unwrap()
    .to_string();
    let mut t: Vec<(String, String)> = files
        .iter()
        .map(|(n, c)| (format!("run/{n}"), c.to_string()))
        .chain([
            ("run/".to_string(), String::new()),
            (format!("run/{OUTPUT_MARKER}"), marker),
        ])
        .collect();
    t.sort();
    t
}

/// A signal whose clean-up has begun removing the staged folder when the
/// commit reaches the exchange: the exchange waits for the clean-up, and
/// the process ends with the previous run's folder whole and nothing else.
/// Unfixed, the exchange went on beside the removal, which then removed
/// the rest of the old folder through its path while DIR held the new
/// one, short of the file removed first (DIR emptied, at the signal's
/// worst moment).
#[test]
fn a_signal_during_the_exchange_leaves_the_previous_run() {
    let _serial = long_hold();
    let (_dir, root, staged) = old_committed_new_staged();
    let (started_tx, started_rx) = channel();
    let left = std::rc::Rc::new(std::cell::RefCell::new(None));
    let slot = left.clone();
    let result = with_hook(
        move |p| {
            if p == Point::Swapping {
                let started_tx = started_tx.clone();
                // The clean-up removes one file, then pauses; unfixed, the
                // exchange happens meanwhile.
                *slot.borrow_mut() = Some(cleanup(root.clone(), move || {
                    started_tx.send(()).unwrap();
                    std::thread::sleep(PAUSE);
                }));
                started_rx.recv_timeout(PATIENCE).unwrap();
            }
        },
        || staged.commit(),
    );
    let left = left
        .borrow_mut()
        .take()
        .unwrap()
        .recv_timeout(PATIENCE)
        .unwrap();
    assert_eq!(left, only(OLD), "the process would leave this ({result:?})");
}

/// Without an atomic exchange (forced here, as on systems and filesystems
/// without one), a signal between the two renames waits for the second:
/// the process ends with the new run in DIR and the old one removed.
/// Unfixed, the clean-up removed the old folder (moved aside) and the new
/// one (still staged): DIR was gone.
#[test]
fn a_signal_between_the_renames_leaves_the_new_run() {
    let _serial = long_hold();
    let (_dir, root, staged) = old_committed_new_staged();
    NO_EXCHANGE.with(|n| n.set(true));
    let left = std::rc::Rc::new(std::cell::RefCell::new(None));
    let slot = left.clone();
    let result = with_hook(
        move |p| {
            if p == Point::BetweenRenames {
                let rx = cleanup(root.clone(), || {});
                // Fixed, the clean-up waits for the lock the swap holds.
                *slot.borrow_mut() = Some(match rx.recv_timeout(PAUSE) {
                    Ok(tree) => Ok(tree),
                    Err(_) => Err(rx),
                });
            }
        },
        || staged.commit(),
    );
    NO_EXCHANGE.with(|n| n.set(false));
    let left = match left.borrow_mut().take().unwrap() {
        Ok(tree) => tree,
        Err(rx) => rx.recv_timeout(PATIENCE).unwrap(),
    };
    assert_eq!(left, only(NEW), "the process would leave this ({result:?})");
    assert!(result.is_ok(), "{result:?}");
}

/// The exchange-less swap without a signal: the new folder in place, the
/// old one and the empty folder it was moved into gone.
#[test]
fn the_swap_without_an_exchange_replaces_the_folder() {
    let (dir, out) = crate::io::scratch("run");
    run(&out, OLD).commit().unwrap();
    NO_EXCHANGE.with(|n| n.set(true));
    let r = run(&out, NEW).commit();
    NO_EXCHANGE.with(|n| n.set(false));
    r.unwrap();
    assert_eq!(tree(dir.path()), only(NEW));
}

/// The clean-up removes a staged folder that the main thread goes on
/// writing into (a file appears after the clean-up listed the folder).
/// Unfixed, one pass found the folder not empty at the end and left it
/// (a `.ssskit-PID-*.tmp` folder after an interrupt).
#[test]
fn the_cleanup_removes_a_folder_that_grows_meanwhile() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_path_buf();
    let staged = run(&root.join("run"), NEW);
    let late = staged.path().join("late.txt");
    let left = cleanup(root.clone(), move || std::fs::write(&late, "late").unwrap())
        .recv_timeout(PATIENCE)
        .unwrap();
    assert_eq!(left, vec![], "left behind");
    drop(staged);
}

/// A destination whose parent folders are missing: they are made at the
/// commit, not before; a run dropped before it (a failure) made none.
#[test]
fn missing_parent_folders_are_made_at_the_commit_only() {
    let (dir, out) = crate::io::scratch("a/b/run");
    let s = run(&out, NEW);
    assert!(!dir.path().join("a").exists(), "made before the work");
    drop(s);
    assert_eq!(tree(dir.path()), vec![], "a failed run left this");
    run(&out, NEW).commit().unwrap();
    assert_eq!(std::fs::read_to_string(out.join("b1.txt")).unwrap(), "new");
    let e = StagedDir::new(&dir.path().join("a/b/run/b1.txt/x/run"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("b1.txt' is not a folder"), "{e}");
}
