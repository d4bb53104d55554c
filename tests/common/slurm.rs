//! A one-node Slurm cluster of its own for a test: munge and Slurm 22.05
//! (Debian's `munge` and `slurm-wlm`, installed by scripts/setup) started in
//! a temporary folder on free ports, with the spool, state, logs and munge
//! key there, and stopped when the guard drops, also when the test fails
//! (a panic unwinds through `Drop`). Nothing outside the folder is touched:
//! the client commands find the cluster through `SLURM_CONF`, which
//! [`Cluster::command`] sets.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// How long the daemons get to answer `sinfo` with an idle node: they start
/// in about a second here; a loaded CI machine gets ample slack.
const START_TIMEOUT: Duration = Duration::from_secs(60);

/// A running one-node cluster.
pub struct Cluster {
    dir: tempfile::TempDir,
    daemons: Vec<(&'static str, Child)>,
}

/// A port nothing listens on now (the kernel's pick, released at once).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

fn short_hostname() -> String {
    let out = Command::new("hostname")
        .arg("-s")
        .output()
        .expect("hostname runs");
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

fn need(program: &str) {
    let found = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).any(|d| d.join(program).is_file()))
        .unwrap_or(false)
        || Path::new("/usr/sbin").join(program).is_file();
    assert!(
        found,
        "{program} not found: the Slurm tests need Debian's slurm-wlm and munge \
         (scripts/setup installs them)"
    );
}

impl Cluster {
    /// Starts munged, slurmctld and slurmd, and waits for an idle node.
    pub fn start() -> Cluster {
        for p in ["munged", "slurmctld", "slurmd", "sbatch", "sinfo", "squeue"] {
            need(p);
        }
        let dir = tempfile::tempdir().expect("a temporary folder");
        let mut c = Cluster {
            dir,
            daemons: Vec::new(),
        };
        let d = c.dir.path().to_path_buf();
        for sub in ["munge", "state", "spool", "log"] {
            std::fs::create_dir(d.join(sub)).unwrap();
        }
        let mut key = vec![0u8; 1024];
        use std::io::Read;
        std::fs::File::open("/dev/urandom")
            .and_then(|mut f| f.read_exact(&mut key))
            .expect("a random munge key");
        std::fs::write(d.join("munge/munge.key"), key).unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(d.join("munge"), std::fs::Permissions::from_mode(0o711)).unwrap();
        std::fs::set_permissions(
            d.join("munge/munge.key"),
            std::fs::Permissions::from_mode(0o600),
        )
        .unwrap();
        let socket = d.join("munge/socket");
        let munged = Command::new("munged")
            .arg("--foreground")
            .arg("--force")
            .arg(format!("--socket={}", socket.display()))
            .arg(format!(
                "--key-file={}",
                d.join("munge/munge.key").display()
            ))
            .arg(format!("--log-file={}", d.join("log/munged.log").display()))
            .arg(format!(
                "--pid-file={}",
                d.join("munge/munged.pid").display()
            ))
            .arg(format!("--seed-file={}", d.join("munge/seed").display()))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("munged starts");
        c.daemons.push(("munged", munged));
        c.wait_for("munge socket", || socket.exists());
        let host = short_hostname();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let conf = format!(
            "ClusterName=ssskit-test\n\
             SlurmctldHost={host}(127.0.0.1)\n\
             AuthType=auth/munge\nCredType=cred/munge\n\
             AuthInfo=socket={socket}\n\
             SlurmUser=root\nSlurmdUser=root\n\
             SlurmctldPort={ctld}\nSlurmdPort={slurmd}\n\
             StateSaveLocation={d}/state\nSlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\nSlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/log/slurmctld.log\nSlurmdLogFile={d}/log/slurmd.log\n\
             ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
             SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n\
             ReturnToService=2\nMpiDefault=none\n\
             JobAcctGatherType=jobacct_gather/none\n\
             AccountingStorageType=accounting_storage/none\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
             PartitionName=main Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
            socket = socket.display(),
            ctld = free_port(),
            slurmd = free_port(),
            d = d.display(),
        );
        std::fs::write(d.join("slurm.conf"), conf).unwrap();
        for (name, args) in [("slurmctld", &["-D", "-i"][..]), ("slurmd", &["-D"][..])] {
            let child = Command::new(name)
                .args(args)
                .env("SLURM_CONF", d.join("slurm.conf"))
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap_or_else(|e| panic!("{name} starts: {e}"));
            c.daemons.push((name, child));
        }
        c.wait_for("an idle node", || {
            let out = c.command("sinfo").args(["-h", "-o", "%t"]).output();
            out.is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle")
        });
        c
    }

    /// The cluster's folder (logs under `log/`).
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// A client command (sbatch, squeue, a script that calls them) that
    /// talks to this cluster.
    pub fn command(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", self.dir.path().join("slurm.conf"));
        c
    }

    /// Waits until none of `jobs` is queued or running (or `timeout`
    /// passes: a panic that names the jobs and the daemons' logs).
    pub fn wait_jobs(&self, jobs: &[String], timeout: Duration) {
        let list = jobs.join(",");
        self.wait_until(&format!("jobs {list} to end"), timeout, || {
            let out = self
                .command("squeue")
                .args(["-h", "-j", &list, "-o", "%i"])
                .output()
                .expect("squeue runs");
            out.status.success() && out.stdout.iter().all(|b| b.is_ascii_whitespace())
        });
    }

    fn wait_for(&self, what: &str, ok: impl FnMut() -> bool) {
        self.wait_until(what, START_TIMEOUT, ok)
    }

    fn wait_until(&self, what: &str, timeout: Duration, mut ok: impl FnMut() -> bool) {
        let t0 = Instant::now();
        while !ok() {
            if t0.elapsed() > timeout {
                panic!("waited {timeout:?} for {what}; logs:\n{}", self.logs());
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The daemons' log tails, for a failure message.
    pub fn logs(&self) -> String {
        let mut s = String::new();
        for f in ["munged.log", "slurmctld.log", "slurmd.log"] {
            let text = std::fs::read_to_string(self.dir().join("log").join(f)).unwrap_or_default();
            let tail: Vec<&str> = text.lines().rev().take(15).collect();
            s += &format!("--- {f}\n");
            for l in tail.iter().rev() {
                s += l;
                s.push('\n');
            }
        }
        s
    }
}

impl Drop for Cluster {
    /// Cancels what is left and stops the daemons, newest first.
    fn drop(&mut self) {
        let _ = self.command("scancel").args(["--user", "root"]).output();
        while let Some((_, mut child)) = self.daemons.pop() {
            // SIGTERM is how each daemon is asked to stop; a daemon that
            // does not within the wait is killed.
            unsafe {
                libc::kill(child.id() as i32, libc::SIGTERM);
            }
            let t0 = Instant::now();
            while t0.elapsed() < Duration::from_secs(10) {
                if let Ok(Some(_)) = child.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// Where a test's own files for the cluster go.
pub fn work_dir(c: &Cluster, name: &str) -> PathBuf {
    let d = c.dir().join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}
