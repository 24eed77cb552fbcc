//! What it takes to reproduce a report: the command line, the program's version and git
//! revision, the seed, the date, and the machine it ran on.

use std::process::Command;

use super::Ctx;

/// `(key, value)` pairs, in the order the page shows them.
pub fn collect(ctx: &Ctx) -> Vec<(String, String)> {
    let args = ctx.args;
    let mut v = vec![
        ("command".to_string(), command_line()),
        (
            "fovea version".to_string(),
            env!("CARGO_PKG_VERSION").to_string(),
        ),
        ("git revision".to_string(), git_revision()),
        (
            "seed".to_string(),
            format!("{} (the flicker section's synthesised gaze)", args.seed),
        ),
        (
            "date (UTC)".to_string(),
            humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
        ),
        (
            "scene".to_string(),
            format!(
                "{} ({} triangles, {} lights)",
                args.scene.scene,
                ctx.loaded.world.tris.len(),
                ctx.loaded.world.lights.len()
            ),
        ),
        (
            "display".to_string(),
            format!(
                "{} {}×{}, {:.1} px/deg",
                ctx.display.name,
                ctx.display.width_px,
                ctx.display.height_px,
                ctx.display.ppd()
            ),
        ),
        (
            "gaze".to_string(),
            format!(
                "({:.0}, {:.0}) px",
                ctx.gaze.point.x_px, ctx.gaze.point.y_px
            ),
        ),
        (
            "BVH".to_string(),
            ctx.loaded.world.caster.backend().name().to_string(),
        ),
        (
            "quick".to_string(),
            if args.quick { "yes" } else { "no" }.to_string(),
        ),
    ];
    v.extend(machine());
    v
}

/// The command line, each argument quoted where a shell would need it.
fn command_line() -> String {
    std::env::args()
        .map(|a| {
            if !a.is_empty()
                && a.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_=.,/:+@%".contains(c))
            {
                a
            } else {
                format!("'{}'", a.replace('\'', r"'\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// `git rev-parse HEAD` of the source tree the program was built from, marked when the tree
/// has uncommitted changes; says why when it cannot be found.
fn git_revision() -> String {
    let src = env!("CARGO_MANIFEST_DIR");
    let git = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .current_dir(src)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match git(&["rev-parse", "HEAD"]) {
        Some(rev) => {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{rev} with uncommitted changes")
            } else {
                rev
            }
        }
        None => format!("unknown (no git repository at {src}, or git is not installed)"),
    }
}

/// Host, CPU, threads, memory, operating system.
fn machine() -> Vec<(String, String)> {
    let read = |p: &str| std::fs::read_to_string(p).unwrap_or_default();
    let cpuinfo = read("/proc/cpuinfo");
    let cpu = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split(':').nth(1))
        .map_or_else(
            || std::env::consts::ARCH.to_string(),
            |s| s.trim().to_string(),
        );
    let mem_gib = read("/proc/meminfo")
        .lines()
        .find(|l| l.starts_with("MemTotal:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or("unknown".to_string(), |kb| {
            format!("{:.1} GiB", kb / 1024.0 / 1024.0)
        });
    let os = read("/etc/os-release")
        .lines()
        .find(|l| l.starts_with("PRETTY_NAME="))
        .map(|l| {
            l.trim_start_matches("PRETTY_NAME=")
                .trim_matches('"')
                .to_string()
        })
        .unwrap_or_else(|| std::env::consts::OS.to_string());
    let host = read("/proc/sys/kernel/hostname").trim().to_string();
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    vec![
        (
            "machine".to_string(),
            if host.is_empty() {
                "unknown".into()
            } else {
                host
            },
        ),
        ("CPU".to_string(), cpu),
        (
            "threads".to_string(),
            format!(
                "{} (rayon), {cores} logical CPUs available",
                rayon::current_num_threads()
            ),
        ),
        ("memory".to_string(), mem_gib),
        (
            "operating system".to_string(),
            format!("{os} ({})", std::env::consts::ARCH),
        ),
    ]
}
