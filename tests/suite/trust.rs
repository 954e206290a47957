//! Issue #30's reproductions, each a test: a verdict cannot be forged
//! through the cache, a full disk cannot poison it, a hung tool cannot hang
//! fxshade, sizes are checked before work, outputs are whole or absent, no
//! file of the user's is lost, and user strings cannot inject into
//! generated files.

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::common::*;

fn no_panic(o: &std::process::Output) {
    assert!(!text(o).contains("panicked"), "panic: {}", text(o));
}

/// A command running the fxshade binary with a scratch cache.
fn fx(cache: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_fxshade"));
    c.env("FXSHADE_CACHE_DIR", cache);
    c
}

/// Write an executable shell script.
fn script(path: &Path, body: &str) {
    std::fs::write(path, format!("#!/bin/sh\n{body}\n")).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// `PATH` with `dir` first.
fn path_with(dir: &Path) -> String {
    format!(
        "{}:{}",
        dir.display(),
        std::env::var("PATH").unwrap_or_default()
    )
}

/// Whether a process exists (a zombie counts as gone).
fn alive(pid: i32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .map(|s| {
            // The state field follows the parenthesised command name.
            let state = s.rsplit(')').next().unwrap_or("").trim_start();
            !state.starts_with('Z') && !state.starts_with('X')
        })
        .unwrap_or(false)
}

/// Wait until `pid` is gone. The bound is a hang guard for a broken build
/// of fxshade, far above the microseconds a SIGKILL takes: the outcome
/// does not depend on the machine's load.
fn wait_gone(pid: i32) -> bool {
    for _ in 0..6000 {
        if !alive(pid) {
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    false
}

/// Wait until `file` exists and holds a line (no deadline but a hang
/// guard: the test waits for an event, not for a time).
fn wait_for_line(file: &Path) -> String {
    for _ in 0..6000 {
        if let Ok(s) = std::fs::read_to_string(file) {
            if s.ends_with('\n') {
                return s;
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    panic!("{} never appeared", file.display());
}

/// The cache entry directories of `unit` on `sim` under `cache`.
fn entries(cache: &Path, unit: &str, sim: &str) -> Vec<PathBuf> {
    let prefix = format!("{unit}-{sim}-");
    let mut v: Vec<PathBuf> = std::fs::read_dir(cache)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with(&prefix))
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// #30.1: a simulator planted (or replaced) in a cache entry is never run:
/// a cache hit verifies the binary's hash recorded when it was built, a
/// cache directory someone else could write is refused, and the old shared
/// fallback under the temporary directory is not looked at.
#[test]
fn a_planted_simulator_is_never_run() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let run = |extra: &[(&str, &str)]| {
        let mut c = fx(&cache);
        c.args([
            "rtl-check",
            "normalize",
            "--count",
            "200",
            "--jobs",
            "1",
            "--json",
        ]);
        for (k, v) in extra {
            c.env(k, v);
        }
        c.output().unwrap()
    };
    let o = run(&[]);
    assert!(o.status.success(), "{}", text(&o));
    let e = entries(&cache, "normalize", "verilator");
    assert_eq!(e.len(), 1, "{e:?}");
    // Replace the built simulator with a forger that says everything passed.
    let forged = dir.path().join("forger-ran");
    let sim = e[0].join("obj/sim");
    script(
        &sim,
        &format!(
            "echo ran > '{}'\necho '200 passed, 0 failed'\necho 'latency 4'",
            forged.display()
        ),
    );
    let o = run(&[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!forged.exists(), "the planted simulator was run");
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        j["build_seconds"].as_f64().unwrap() > 0.0,
        "rebuilt, not trusted: {j}"
    );
    // An entry whose seal is the old empty `done` is rebuilt too.
    let e = entries(&cache, "normalize", "verilator");
    std::fs::write(e[0].join("done"), b"").unwrap();
    script(
        &e[0].join("obj/sim"),
        &format!("echo ran > '{}'", forged.display()),
    );
    let o = run(&[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!forged.exists(), "an unsealed entry was run");

    // A cache others can write is refused, with the fix named.
    std::fs::set_permissions(&cache, std::fs::Permissions::from_mode(0o777)).unwrap();
    let o = run(&[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("not safe to use") && text(&o).contains("others can write"),
        "{}",
        text(&o)
    );
    std::fs::set_permissions(&cache, std::fs::Permissions::from_mode(0o700)).unwrap();
    // Another user's cache directory or entry (root can make one; other
    // users are checked by the mode test above and the model's unit test).
    if unsafe { libc::geteuid() } == 0 {
        let e = entries(&cache, "normalize", "verilator");
        std::os::unix::fs::chown(&e[0], Some(65534), Some(65534)).unwrap();
        let o = run(&[]);
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
        assert!(text(&o).contains("owned by uid 65534"), "{}", text(&o));
        let theirs = dir.path().join("theirs");
        std::fs::create_dir(&theirs).unwrap();
        std::os::unix::fs::chown(&theirs, Some(65534), Some(65534)).unwrap();
        let mut c = fx(&theirs);
        let o = c
            .args(["rtl-check", "normalize", "--count", "200"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
        assert!(text(&o).contains("owned by uid 65534"), "{}", text(&o));
    }

    // With no HOME and no cache variable, the old shared fallback
    // `$TMPDIR/fxshade-cache` is not where fxshade looks: an entry planted
    // there (under the key a real run uses) is never run.
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    let home = dir.path().join("home");
    let mut c = Command::new(env!("CARGO_BIN_EXE_fxshade"));
    c.args(["rtl-check", "normalize", "--count", "200", "--jobs", "1"])
        .env_clear()
        .env("PATH", std::env::var("PATH").unwrap())
        .env("FXSHADE_QUICK_BUILD", "1")
        .env("TMPDIR", &tmp)
        .env("HOME", &home);
    let o = c.output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let real = entries(&home.join(".cache/fxshade"), "normalize", "verilator");
    assert_eq!(real.len(), 1);
    let planted = tmp.join("fxshade-cache").join(real[0].file_name().unwrap());
    std::fs::create_dir_all(planted.join("obj")).unwrap();
    std::fs::write(planted.join("done"), b"").unwrap();
    script(
        &planted.join("obj/sim"),
        &format!("echo ran > '{}'", forged.display()),
    );
    let o = c.env_remove("HOME").output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(!forged.exists(), "the shared fallback was used");
}

/// Run `sh_script` in a private mount namespace (so it may mount a small
/// tmpfs), as the user itself where user namespaces allow, else as root.
fn in_mount_namespace(sh_script: &str) -> std::process::Output {
    let try_ = |args: &[&str]| {
        Command::new("unshare")
            .args(args)
            .args(["sh", "-c", sh_script])
            .output()
    };
    let probe = |args: &[&str]| {
        Command::new("unshare")
            .args(args)
            .args(["sh", "-c", "mount -t tmpfs -o size=64k tmpfs /mnt"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if probe(&["-rm"]) {
        try_(&["-rm"]).unwrap()
    } else if probe(&["-m"]) {
        try_(&["-m"]).unwrap()
    } else {
        panic!(
            "this test needs a mount namespace for a small tmpfs: run it as root, or enable \
             unprivileged user namespaces (sysctl kernel.unprivileged_userns_clone=1)"
        )
    }
}

/// #30.2 and #30.5: on a full file system a simulator build is an error
/// that says so and leaves no entry marked complete (the next run, with
/// space, builds and passes), and a waveform cut short is an error, not a
/// success.
#[test]
fn a_full_disk_is_an_error_and_poisons_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mnt = dir.path().join("mnt");
    std::fs::create_dir(&mnt).unwrap();
    let fx = env!("CARGO_BIN_EXE_fxshade");
    let m = mnt.display();
    // Icarus's program for normalize is a few hundred KiB: a 2 MiB file
    // system with all but 40 KiB filled cuts it short.
    let sh = format!(
        "set -u
mount -t tmpfs -o size=2m tmpfs '{m}' || exit 99
mkdir '{m}/cache'
head -c $(( 2048*1024 - 40*1024 )) /dev/zero > '{m}/filler' 2>/dev/null
echo '--- full'
FXSHADE_CACHE_DIR='{m}/cache' '{fx}' rtl-check normalize --sim icarus --count 200 --jobs 1 2>&1
echo \"status $?\"
ls -a '{m}/cache'/normalize-icarus-* 2>/dev/null | grep -c '^done$' | sed 's/^/sealed /'
rm '{m}/filler'
echo '--- free'
FXSHADE_CACHE_DIR='{m}/cache' '{fx}' rtl-check normalize --sim icarus --count 200 --jobs 1 2>&1
echo \"status $?\"
echo '--- trace'
head -c $(( 2048*1024 - 300*1024 )) /dev/zero > '{m}/filler' 2>/dev/null
FXSHADE_CACHE_DIR='{dir}/cache2' '{fx}' rtl-check normalize --count 3000 --jobs 1 --trace '{m}/t.fst' 2>&1
echo \"status $?\"
ls '{m}/t.fst' 2>/dev/null | sed 's/^/left /'
",
        dir = dir.path().display()
    );
    let o = in_mount_namespace(&sh);
    let out = text(&o);
    assert_ne!(o.status.code(), Some(99), "{out}");
    let part = |name: &str| {
        out.split(&format!("--- {name}\n"))
            .nth(1)
            .unwrap_or("")
            .split("\n--- ")
            .next()
            .unwrap_or("")
            .to_string()
    };
    let full = part("full");
    assert!(full.contains("status 1"), "{out}");
    assert!(
        full.contains("full") && full.contains("no space left"),
        "the error says the disk is full: {out}"
    );
    assert!(!full.contains("sealed 1"), "an entry was sealed: {out}");
    assert!(!full.contains("panicked"), "{out}");
    let free = part("free");
    assert!(
        free.contains("status 0"),
        "with space, it builds and passes: {out}"
    );
    let trace = part("trace");
    assert!(trace.contains("status 1"), "{out}");
    assert!(
        trace.contains("waveform") && trace.contains("full"),
        "a waveform cut short is an error: {out}"
    );
    assert!(
        !trace.contains("left "),
        "the partial waveform stays: {out}"
    );
}

/// #30.3: a tool that hangs (a licence server, a stale NFS mount) stops
/// fxshade with an error naming it and the variable that raises the limit,
/// and nothing it started is left running; SIGKILL of fxshade during a
/// build leaves no tool behind either. A fake `verilator` stands in for a
/// hung one: what it does does not depend on time, so neither does the
/// test.
#[test]
fn a_hung_tool_stops_with_an_error_and_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    let pids = dir.path().join("pids");
    // Hangs on the version probe, with a child of its own.
    script(
        &bin.join("verilator"),
        &format!(
            "sleep 100000 &\necho \"$$ $!\" >> '{}'\nwait",
            pids.display()
        ),
    );
    let o = fx(&dir.path().join("cache"))
        .args(["rtl-check", "normalize", "--count", "200"])
        .env("PATH", path_with(&bin))
        .env("FXSHADE_PROBE_TIMEOUT", "2")
        .output()
        .unwrap();
    no_panic(&o);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("verilator -V") && text(&o).contains("FXSHADE_PROBE_TIMEOUT"),
        "{}",
        text(&o)
    );
    let line = wait_for_line(&pids);
    for pid in line.split_whitespace() {
        assert!(
            wait_gone(pid.parse().unwrap()),
            "process {pid} left running"
        );
    }

    // A build that is under way when fxshade is killed: answers the probe,
    // then blocks in the build.
    std::fs::remove_file(&pids).unwrap();
    script(
        &bin.join("verilator"),
        &format!(
            "[ \"$1\" = -V ] && {{ echo 'Verilator 5.0'; exit 0; }}\n\
             sleep 100000 &\necho \"$$ $!\" >> '{}'\nwait",
            pids.display()
        ),
    );
    let mut child = fx(&dir.path().join("cache"))
        .args(["rtl-check", "interp", "--count", "200"])
        .env("PATH", path_with(&bin))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let line = wait_for_line(&pids);
    child.kill().unwrap(); // SIGKILL
    let _ = child.wait();
    for pid in line.split_whitespace() {
        assert!(
            wait_gone(pid.parse().unwrap()),
            "process {pid} of the killed build left running"
        );
    }
}

/// #30.4: every size is checked before work starts and refused with the
/// flag, the limit and the reason (status 2); nothing is read without
/// bound; a fine procedural mesh renders within memory.
#[test]
fn sizes_are_checked_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v");
    let o_ = out.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "vectors",
                "normalize",
                "--count",
                "18446744073709551615",
                "--no-hex",
                "--out",
                o_,
            ],
            "2^32",
        ),
        (
            // One past the 32-bit index: it would wrap to 0.
            vec!["vectors", "normalize", "--count", "4294967297", "--out", o_],
            "32-bit index",
        ),
        (
            vec!["mutate", "normalize", "--count", "99999999999"],
            "--count 99999999999",
        ),
        (
            vec!["rtl-check", "normalize", "--count", "99999999999"],
            "2^32",
        ),
        (
            vec!["explore", "--samples", "18446744073709551615", "--out", o_],
            "--samples",
        ),
        (vec!["error", "interp", "--count", "99999999999"], "--count"),
        (
            vec!["error", "normalize", "--count", "99999999999"],
            "--count",
        ),
        (vec!["error", "polar", "--count", "99999999999"], "--count"),
        (vec!["error", "angles", "--count", "99999999999"], "--count"),
        (vec!["config", "check", "/dev/zero"], "larger than 64 MiB"),
        (
            vec!["explore", "--sweep", "/dev/zero", "--out", o_],
            "larger than 64 MiB",
        ),
        (
            vec!["explore", "--merge", "/dev/zero", "--out", o_],
            "larger than 64 MiB",
        ),
        (vec!["merge", "/dev/zero"], "larger than 64 MiB"),
        (vec!["config", "check", "/tmp"], "is a directory"),
        (vec!["error", "normalize", "--theta", "nan"], "--theta"),
        (
            vec![
                "render", "--mesh", "sphere:8", "--light", "nan,1,1", "--out", o_,
            ],
            "--light",
        ),
    ];
    for (args, want) in cases {
        let o = fxshade(&args);
        no_panic(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        assert!(text(&o).contains(want), "{args:?}: {}", text(&o));
        assert!(
            !text(&o).contains("os error 21): Is a directory"),
            "{}",
            text(&o)
        );
    }
    assert!(!out.exists(), "nothing was written");
    // The documented largest procedural mesh renders (its triangles are set
    // up only where pixels show them).
    let o = fxshade(&[
        "render",
        "--mesh",
        "sphere:4096",
        "--size",
        "32x32",
        "--method",
        "quadratic",
        "--out",
        o_,
    ]);
    no_panic(&o);
    assert!(o.status.success(), "{}", text(&o));
}

/// #30.6: no file of the user's is lost: a file added to (or changed in) a
/// directory fxshade wrote, a hand-edited module in `rtl --out`, a picture
/// that would overwrite another output or the input, a user's file at the
/// `--trace` path: each is refused, named, unless `--force`; a killed run's
/// staging directory is removed by the next run in the same parent,
/// whatever its name.
#[test]
fn no_file_of_the_users_is_lost() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("d");
    let ds = d.to_str().unwrap();
    let vectors = |seed: &str, force: bool| {
        let mut a = vec![
            "vectors",
            "normalize",
            "--count",
            "200",
            "--seed",
            seed,
            "--out",
            ds,
        ];
        if force {
            a.push("--force");
        }
        fxshade(&a)
    };
    assert!(vectors("1", false).status.success());
    std::fs::write(d.join("mine.txt"), b"mine").unwrap();
    let o = vectors("2", false);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("mine.txt") && text(&o).contains("--force"),
        "{}",
        text(&o)
    );
    assert_eq!(std::fs::read(d.join("mine.txt")).unwrap(), b"mine");
    std::fs::remove_file(d.join("mine.txt")).unwrap();
    // A file fxshade wrote, then edited.
    std::fs::write(d.join("inputs.hex"), b"edited\n").unwrap();
    let o = vectors("2", false);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("inputs.hex") && text(&o).contains("changed since"),
        "{}",
        text(&o)
    );
    assert!(vectors("2", true).status.success());
    assert!(
        vectors("3", false).status.success(),
        "its own files, unchanged"
    );

    // `rtl --out`: a hand-edited module, and a user's own file of that name.
    let r = dir.path().join("r");
    let rs = r.to_str().unwrap();
    assert!(fxshade(&["rtl", "normalize", "--out", rs]).status.success());
    let v = std::fs::read_to_string(r.join("normalize.v")).unwrap();
    std::fs::write(r.join("normalize.v"), v.replace("GENERATED", "EDITED")).unwrap();
    let o = fxshade(&[
        "rtl",
        "normalize",
        "--set",
        "normalize.theta=0.4",
        "--out",
        rs,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("normalize.v") && text(&o).contains("changed since"),
        "{}",
        text(&o)
    );
    assert!(std::fs::read_to_string(r.join("normalize.v"))
        .unwrap()
        .contains("EDITED"));
    let o = fxshade(&["rtl", "normalize", "--force", "--out", rs]);
    assert!(o.status.success(), "{}", text(&o));
    // Unchanged since: replaced without a flag.
    let o = fxshade(&[
        "rtl",
        "normalize",
        "--set",
        "normalize.theta=0.4",
        "--out",
        rs,
    ]);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::write(r.join("interp.v"), b"module interp; endmodule\n").unwrap();
    let o = fxshade(&["rtl", "all", "--out", rs]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("interp.v") && text(&o).contains("not written by fxshade"));
    assert!(!r.join("angles.v").exists(), "nothing was written");

    // bake-implied: the flags picture onto the converted map, or either
    // onto the input.
    // (The clash is refused before the input is read.)
    let png = dir.path().join("in.png");
    std::fs::write(&png, b"not read").unwrap();
    let x = dir.path().join("x.png");
    let (xs, ps) = (x.to_str().unwrap(), png.to_str().unwrap());
    for args in [
        vec!["--normal-map", ps, "--out", xs, "--flags", xs],
        vec!["--normal-map", ps, "--out", ps],
        vec!["--normal-map", ps, "--out", xs, "--flags", ps],
    ] {
        let mut a = vec!["bake-implied", "--mesh", "sphere:8"];
        a.extend(args);
        let o = fxshade(&a);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {}", text(&o));
        assert!(text(&o).contains("are the same file"), "{}", text(&o));
    }
    assert!(!x.exists());

    // A user's file at the --trace path.
    let mine = dir.path().join("notes.fst");
    std::fs::write(&mine, b"my notes").unwrap();
    let o = fxshade(&[
        "rtl-check",
        "normalize",
        "--count",
        "200",
        "--trace",
        mine.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert_eq!(std::fs::read(&mine).unwrap(), b"my notes");

    // A staging directory a killed run left beside another output.
    let stale = dir.path().join(".report.staging-999999999");
    std::fs::create_dir(&stale).unwrap();
    std::fs::write(stale.join(".fxshade-output"), b"").unwrap();
    assert!(vectors("1", false).status.success());
    assert!(!stale.exists(), "the dead run's staging directory is left");
}

/// A directory name holding everything that could end a comment, start a
/// directive or run a command in a generated file: newlines, `*/`, a
/// backtick directive, quotes, `$()`, HTML.
const NASTY: &str =
    "d\n`define EVIL 1\nmodule evil; endmodule\n*/ \"q\" 'q' $(touch PWNED) <b>x</b> \u{398}";

/// Every generated text file under `dir`: no line that an injected string
/// could have made live, nothing non-ASCII in Verilog, and every TOML file
/// parses as a configuration again.
fn check_generated(dir: &Path, what: &str) {
    let mut stack = vec![dir.to_path_buf()];
    let mut n = 0;
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            let Ok(t) = std::fs::read_to_string(&p) else {
                continue;
            };
            n += 1;
            for l in t.lines() {
                let l = l.trim_start();
                assert!(
                    !l.starts_with("`define EVIL") && !l.starts_with("module evil"),
                    "{what}: {} has a live injected line: {l}",
                    p.display()
                );
            }
            let ext = p.extension().map(|x| x.to_string_lossy().into_owned());
            if ext.as_deref() == Some("html") {
                assert!(
                    !t.contains("<b>x</b>"),
                    "{what}: raw HTML in {}",
                    p.display()
                );
            }
            match ext.as_deref() {
                Some("v") => assert!(t.is_ascii(), "{what}: non-ASCII in {}", p.display()),
                Some("toml") => {
                    let o = fxshade(&["config", "check", p.to_str().unwrap()]);
                    assert!(o.status.success(), "{what}: {}: {}", p.display(), text(&o));
                }
                _ => {}
            }
        }
    }
    assert!(n > 0, "{what}: no files under {}", dir.display());
}

/// #30.7: user strings (a configuration path, a mesh path, a waveform path,
/// `--set` values) cannot inject into any generated file: they are escaped
/// for the file's syntax, and control characters in a value are refused.
#[test]
fn user_strings_cannot_inject_into_generated_files() {
    let dir = tempfile::tempdir().unwrap();
    // (`*/` makes a directory `*` in the path: the slash is a separator.)
    let nasty = dir.path().join(NASTY);
    std::fs::create_dir_all(&nasty).unwrap();
    let cfg = nasty.join("my config.toml");
    std::fs::write(&cfg, "[normalize]\ntheta = 0.5\n").unwrap();
    let obj = nasty.join("tri.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0.1 0 1\nvn 0 0.1 1\nvt 0 0\nvt 1 0\nvt 0 1\n\
         f 1/1/1 2/2/2 3/3/3\n",
    )
    .unwrap();
    let c = cfg.to_str().unwrap();
    let out = |n: &str| nasty.join(n).to_str().unwrap().to_string();
    let runs: Vec<Vec<String>> = vec![
        vec![
            "rtl".into(),
            "all".into(),
            "--testbench".into(),
            "--config".into(),
            c.into(),
            "--out".into(),
            out("rtl"),
        ],
        vec![
            "vectors".into(),
            "normalize".into(),
            "--count".into(),
            "200".into(),
            "--config".into(),
            c.into(),
            "--out".into(),
            out("vec"),
        ],
        vec![
            "render".into(),
            "--mesh".into(),
            obj.to_str().unwrap().into(),
            "--size".into(),
            "16x16".into(),
            "--config".into(),
            c.into(),
            "--out".into(),
            out("render"),
        ],
        vec![
            "explore".into(),
            "--vary".into(),
            "normalize.theta=0.4,0.5".into(),
            "--analyses".into(),
            "normalize".into(),
            "--samples".into(),
            "2000".into(),
            "--config".into(),
            c.into(),
            "--no-cache".into(),
            "--out".into(),
            out("explore"),
        ],
    ];
    for args in &runs {
        let a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        let o = fxshade_quick(&a);
        no_panic(&o);
        assert!(o.status.success(), "{:?}: {}", a[0], text(&o));
        check_generated(Path::new(args.last().unwrap()), a[0]);
    }
    // The generated Verilog still passes a strict tool (copied to a plain
    // path: Verilator itself cannot open a file under that directory).
    let plain = dir.path().join("normalize.v");
    std::fs::copy(nasty.join("rtl/normalize.v"), &plain).unwrap();
    let o = Command::new("verilator")
        .args(["--lint-only", "-Wall"])
        .arg(&plain)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    // A waveform into that directory.
    let o = fxshade(&[
        "rtl-check",
        "normalize",
        "--count",
        "200",
        "--trace",
        &out("t.fst"),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(nasty.join("t.fst").is_file());
    // Nothing ran the `$()`.
    assert!(!Path::new("PWNED").exists() && !dir.path().join("PWNED").exists());
    // A control character in a value is refused, naming the flag.
    for set in [
        "normalize.theta=0.5\n\n",
        "normalize.method=\"quadratic\r\"",
        "normalize.theta\n=0.5",
    ] {
        let o = fxshade(&["config", "show", "--set", set]);
        assert_eq!(o.status.code(), Some(2), "{set:?}: {}", text(&o));
        assert!(text(&o).contains("control character"), "{}", text(&o));
        assert!(!text(&o).contains('\r'), "the error itself is escaped");
    }
}

/// Decode the records of a vector file with the manifest's field layout:
/// `{zero pad, index[31:0], fields MSB first}`, big endian, each field
/// sign-extended when its format is signed. Written here from the
/// manifest's description, not with the writer's code.
fn decode(
    bytes: &[u8],
    layout: &serde_json::Value,
) -> Vec<std::collections::BTreeMap<String, i128>> {
    let width = layout["width"].as_u64().unwrap() as usize;
    let rb = (32 + width).div_ceil(8);
    assert_eq!(bytes.len() % rb, 0, "whole records");
    bytes
        .chunks(rb)
        .map(|rec| {
            let bit = |k: usize| (rec[rb - 1 - k / 8] >> (k % 8)) & 1;
            layout["fields"]
                .as_array()
                .unwrap()
                .iter()
                .map(|f| {
                    let (msb, lsb) = (
                        f["msb"].as_u64().unwrap() as usize,
                        f["lsb"].as_u64().unwrap() as usize,
                    );
                    let mut v: i128 = 0;
                    for k in (lsb..=msb).rev() {
                        v = (v << 1) | i128::from(bit(k));
                    }
                    let w = msb - lsb + 1;
                    if f["signed"].as_bool().unwrap() && (v >> (w - 1)) & 1 == 1 {
                        v -= 1i128 << w;
                    }
                    (f["name"].as_str().unwrap().to_string(), v)
                })
                .collect()
        })
        .collect()
}

/// #30.8: every input a vector file holds is the value the model computed
/// its expected outputs from, for every unit and every accepted
/// configuration of the ports' formats (a barycentric port that cannot
/// hold 1.0 among them: its corner rows used to carry 1.0 in the model and
/// 0 in the file). The expected outputs are computed again here from the
/// decoded inputs through the model's compiled trace and must be the
/// file's.
#[test]
fn vector_inputs_are_the_values_the_model_used() {
    use fxshade_model::rtl::units;
    let mut seed = 0x5eed_u64;
    let mut next = |n: u64| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) % n
    };
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0;
    for k in 0..3 {
        // Port formats drawn wide and narrow; the first has the issue's
        // U0F16 barycentrics.
        let mut sets = vec![if k == 0 {
            "interp.bary.format=U0F16".to_string()
        } else {
            format!("interp.bary.format=U{}F{}", next(2), 8 + next(9))
        }];
        sets.push(format!("interp.vertex.format=I2F{}", 8 + next(8)));
        sets.push(format!("normalize.normal.format=I2F{}", 8 + next(8)));
        sets.push(format!("lighting.light.format=I2F{}", 8 + next(8)));
        sets.push(format!("angles.normal.format=I2F{}", 8 + next(8)));
        let mut check = vec!["config", "check", "/dev/null"];
        for s in &sets {
            check.extend(["--set", s.as_str()]);
        }
        if !fxshade(&check).status.success() {
            continue;
        }
        for u in units::all() {
            for (variant, vset) in u.variants.iter().take(if k == 0 { 9 } else { 1 }) {
                let out = dir.path().join(format!("{k}-{}-{variant}", u.name));
                let mut a = vec!["vectors", u.name, "--count", "400", "--no-hex"];
                for s in &sets {
                    a.extend(["--set", s.as_str()]);
                }
                a.extend(crate::common::sets(vset));
                a.extend(["--out", out.to_str().unwrap()]);
                let o = fxshade_quick(&a);
                assert!(o.status.success(), "{a:?}: {}", text(&o));
                let m: serde_json::Value =
                    serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap())
                        .unwrap();
                let ins = decode(
                    &std::fs::read(out.join("inputs.bin")).unwrap(),
                    &m["inputs"],
                );
                let exp = decode(
                    &std::fs::read(out.join("expected.bin")).unwrap(),
                    &m["expected"],
                );
                // The model, on the decoded inputs.
                let mut all: Vec<String> = sets.clone();
                all.extend(units::overrides(vset).map(str::to_string));
                let cfg = fxshade_model::Config::resolve(None, &all).unwrap();
                let d = u.design(&cfg).unwrap();
                let ports = d.trace.input_ports();
                let cols: Vec<Vec<i128>> = ports
                    .iter()
                    .map(|p| ins.iter().map(|r| r[&p.name]).collect())
                    .collect();
                let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
                let outs: Vec<_> = d.trace.output_ports().iter().map(|p| p.value).collect();
                let prog = fxshade_model::datapath::Compiled::compile(&d.trace, &outs).unwrap();
                let (got, _) = prog.run_i128(&refs);
                for (j, p) in d.trace.output_ports().iter().enumerate() {
                    for (i, e) in exp.iter().enumerate() {
                        assert_eq!(
                            got[j][i], e[&p.name],
                            "{} {variant} {sets:?}: vector {i}, output {}: the file's inputs are not the model's",
                            u.name, p.name
                        );
                    }
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 15, "{checked} sets checked");
}

/// #30.10: no result depends on the clock. The library crates (numbers,
/// IR, backend, model: every analysis, search, proof and vector generator) read no
/// clock at all:
/// its budgets are counts, so the same configuration and seed give the
/// same vectors, proofs and scores on any machine at any load; and an
/// exploration measured twice gives the same metrics to the last digit.
#[test]
fn no_result_depends_on_the_clock() {
    let mut stack = vec![
        repo().join("numbers/src"),
        repo().join("ir/src"),
        repo().join("backend/src"),
        repo().join("model/src"),
    ];
    let mut files = 0;
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                files += 1;
                let t = std::fs::read_to_string(&p).unwrap();
                for bad in ["Instant", "SystemTime::now", ".elapsed()"] {
                    assert!(
                        !t.contains(bad),
                        "{} reads the clock ({bad}): a budget must be a count",
                        p.display()
                    );
                }
            }
        }
    }
    assert!(files > 30);
    let dir = tempfile::tempdir().unwrap();
    let run = |n: &str| {
        let out = dir.path().join(n);
        let o = fxshade(&[
            "explore",
            "--vary",
            "normalize.theta=0.4,0.5",
            "--mesh",
            "sphere:12",
            "--mesh",
            "torus:12",
            "--no-cache",
            "--jobs",
            "2",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        let j: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("explore.json")).unwrap()).unwrap();
        j["rows"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["metrics"].to_string())
            .collect::<Vec<_>>()
    };
    assert_eq!(run("a"), run("b"), "the same sweep measured twice differs");
}

/// #30.9 and #30.11: errors name the flag or the file and the key that
/// caused them, every input is checked before work, bad inputs exit 2 with
/// one clear reason, and a command says which configuration it ran.
#[test]
fn errors_name_their_cause() {
    let dir = tempfile::tempdir().unwrap();
    let err = |args: &[&str], code: i32, want: &[&str]| {
        let o = fxshade(args);
        no_panic(&o);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {}", text(&o));
        for w in want {
            assert!(text(&o).contains(w), "{args:?}: no `{w}` in: {}", text(&o));
        }
        text(&o)
    };
    // The flag and the key at fault, not the embedded default's lines.
    let t = err(
        &["config", "show", "--set", "polar.index.overflow=saturate"],
        2,
        &["--set polar.index.overflow=saturate", "`polar.index`"],
    );
    assert!(!t.contains("<default>") && !t.contains("table_bits"), "{t}");
    let t = err(
        &["config", "show", "--set", "normalize.d.format=U0F60"],
        2,
        &["--set normalize.d.format=U0F60", "`normalize.d`"],
    );
    assert!(!t.contains("<default>"), "{t}");
    // A Θ config check accepts works everywhere (its d interval is too
    // narrow for a Remez exchange; the Taylor polynomial serves).
    let cfg = dir.path().join("t.toml");
    std::fs::write(&cfg, "[normalize]\ntheta = 0.9995\n").unwrap();
    err(&["config", "check", cfg.to_str().unwrap()], 0, &["ok"]);
    for cmd in [
        &["error", "interp", "--count", "2000"][..],
        &["error", "normalize", "--count", "2000"][..],
        &["error", "polar", "--count", "2000", "--sampled"][..],
    ] {
        let mut a = cmd.to_vec();
        a.extend(["--config", cfg.to_str().unwrap()]);
        err(&a, 0, &[]);
    }
    // One reason, once.
    let t = err(
        &["config", "check", dir.path().to_str().unwrap()],
        2,
        &["is a directory"],
    );
    assert_eq!(t.matches("irectory").count(), 1, "{t}");
    // --readme is checked before the report's minutes of work.
    let readme = dir.path().join("R.md");
    std::fs::write(&readme, "no markers here\n").unwrap();
    let rep = dir.path().join("rep");
    err(
        &[
            "report",
            "--readme",
            readme.to_str().unwrap(),
            "--out",
            rep.to_str().unwrap(),
        ],
        2,
        &["--readme", "BEGIN found"],
    );
    assert!(!rep.exists());
    // explore's --out is checked before any point is measured.
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), b"mine").unwrap();
    err(
        &[
            "explore",
            "--vary",
            "normalize.theta=0.4,0.5",
            "--out",
            mine.to_str().unwrap(),
        ],
        2,
        &["--out", "not written by fxshade"],
    );
    // A bad sweep file exits 2 whatever the cause.
    for (body, want) in [
        (
            "vary = [\"normalize.theta=0.4,0.5\"]\nbogus = 1\n",
            "unknown key",
        ),
        ("vary = [\n", "s.toml:2"),
        ("mesh = [\"/no/such.obj\"]\n", "no such file"),
        ("set = [\"normalize.theta=7\"]\n", "normalize.theta"),
    ] {
        let f = dir.path().join("s.toml");
        std::fs::write(&f, body).unwrap();
        err(
            &[
                "explore",
                "--sweep",
                f.to_str().unwrap(),
                "--out",
                dir.path().join("e").to_str().unwrap(),
            ],
            2,
            &[want],
        );
    }
    // A binary OBJ is named, not printed.
    let bin = dir.path().join("b.obj");
    let mut bytes = b"v 0 0 0\n".to_vec();
    bytes.extend((0..=255u8).cycle().take(2048));
    std::fs::write(&bin, bytes).unwrap();
    let o = fxshade(&[
        "render",
        "--mesh",
        bin.to_str().unwrap(),
        "--out",
        dir.path().join("r").to_str().unwrap(),
    ]);
    assert_ne!(o.status.code(), Some(0));
    assert!(
        o.stderr.iter().all(|b| b.is_ascii()),
        "raw bytes on the terminal"
    );
    assert!(text(&o).contains("not a text OBJ file"), "{}", text(&o));
    // A command run with --set says so.
    let o = fxshade(&[
        "rtl",
        "normalize",
        "--set",
        "normalize.theta=0.4",
        "--out",
        dir.path().join("v").to_str().unwrap(),
    ]);
    assert!(
        text(&o).contains("<default> with --set normalize.theta=0.4"),
        "{}",
        text(&o)
    );
}

/// #30.9: `explore --merge` refuses a shard whose rows are not the points
/// of its sweep (a row's value edited, or the sweep's values edited).
#[test]
fn a_forged_explore_shard_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let shard = |k: usize| {
        let out = dir.path().join(format!("s{k}"));
        let o = fxshade(&[
            "explore",
            "--vary",
            "normalize.theta=0.4,0.5",
            "--analyses",
            "normalize",
            "--samples",
            "500",
            "--no-cache",
            "--shard",
            &format!("{k}/2"),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        out.join("explore.json")
    };
    let (a, b) = (shard(0), shard(1));
    let merged = dir.path().join("m");
    let merge = |b: &Path| {
        fxshade(&[
            "explore",
            "--merge",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--out",
            merged.to_str().unwrap(),
            "--force",
        ])
    };
    assert!(merge(&b).status.success());
    let text0 = std::fs::read_to_string(&b).unwrap();
    for (from, to) in [
        ("\"0.5\"", "\"0.9\""),
        ("normalize.theta=0.5", "normalize.theta=0.9"),
    ] {
        assert!(text0.contains(from), "{from}");
        let forged = dir.path().join("forged.json");
        std::fs::write(&forged, text0.replacen(from, to, 1)).unwrap();
        let o = merge(&forged);
        assert_ne!(o.status.code(), Some(0), "{from} -> {to}: {}", text(&o));
        assert!(
            text(&o).contains("not point") || text(&o).contains("fingerprint"),
            "{}",
            text(&o)
        );
    }
}

/// The exhaustive analyses are remembered in the user's cache: a second run
/// reads the same figures, a garbled entry is recomputed (never trusted,
/// never an error), and another configuration is another entry.
#[test]
fn remembered_analyses_are_the_computed_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let run = |sets: &[&str]| {
        let mut c = fx(&cache);
        c.args(["error", "polar", "--json"]);
        for s in sets {
            c.args(["--set", s]);
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "{}", text(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let small = ["polar.angle_bits=8", "polar.table_bits=8"];
    let first = run(&small);
    assert!(first.contains("every code (exhaustive)"), "{first}");
    let dir = cache.join("analyses");
    let entries = || -> Vec<PathBuf> {
        std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .collect()
    };
    let files = entries();
    assert_eq!(files.len(), 1, "{files:?}");
    assert_eq!(run(&small), first);
    // A garbled entry: recomputed, and the same figures come out.
    std::fs::write(&files[0], b"{\"max_lsb_err\": 0.0").unwrap();
    assert_eq!(run(&small), first);
    // A plausible entry with other numbers is the user's own file in the
    // user's private cache; but one owned by the user and writable by
    // others is refused.
    std::fs::set_permissions(&files[0], std::fs::Permissions::from_mode(0o666)).unwrap();
    let mut c = fx(&cache);
    let o = c
        .args([
            "error", "polar", "--json", "--set", small[0], "--set", small[1],
        ])
        .output()
        .unwrap();
    no_panic(&o);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("others can write"), "{}", text(&o));
    std::fs::set_permissions(&files[0], std::fs::Permissions::from_mode(0o600)).unwrap();
    // Another table width is another entry with other figures.
    let other = run(&["polar.angle_bits=8", "polar.table_bits=7"]);
    assert_ne!(other, first);
    assert_eq!(entries().len(), 2);
}
