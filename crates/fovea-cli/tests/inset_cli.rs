//! `fovea inset-analysis` on real scenes: the inset paper's gradient table for every boundary
//! smoothing against the full frame (Liu et al., inset boundary smoothing, Sec. 4, Fig. 8).

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn fovea() -> Command {
    Command::cargo_bin("fovea").unwrap()
}

fn shared_scenes() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    if p.is_dir() {
        Some(p)
    } else {
        println!("skipped: ../shared/scenes is absent (a fresh clone); CI has it");
        None
    }
}

/// The slope across the boundary, Area2 − Area3, in x and y.
fn slope(row: &serde_json::Value) -> [f64; 2] {
    let r = &row["report"];
    [
        r["slope_23_x"].as_f64().unwrap(),
        r["slope_23_y"].as_f64().unwrap(),
    ]
}

#[test]
fn smoothing_keeps_area1_and_moves_the_boundary_slope_towards_the_full_frame() {
    let Some(scenes) = shared_scenes() else {
        return;
    };
    let classroom = scenes.join("japanese-classroom/scene.xml");
    let chess = scenes.join("chess-board/chess-board.plain.glb");
    // Two views declared before measuring: the classroom from a seat and the chess board
    // from 0.45 m, each with the inset on the scene's centre of interest.
    let views: Vec<(&str, Vec<String>)> = vec![
        (
            "classroom",
            [
                "--scene",
                classroom.to_str().unwrap(),
                "--camera-pos=-1.4,1.05,4.0",
                "--look-at=-1.0,0.7,0.0",
                "--gaze",
                "820,850",
            ]
            .map(String::from)
            .to_vec(),
        ),
        (
            "chess",
            [
                "--scene",
                chess.to_str().unwrap(),
                "--scene-scale",
                "0.002",
                "--camera-pos",
                "0,0.25,0.36",
                "--look-at",
                "0,0.03,0.0",
                "--gaze",
                "600,950",
            ]
            .map(String::from)
            .to_vec(),
        ),
    ];
    let tmp = tempfile::tempdir().unwrap();
    for (name, view) in views {
        let out = tmp.path().join(name);
        let mut args = vec!["inset-analysis".to_string()];
        args.extend(view.clone());
        args.extend(
            [
                "--lights",
                "4",
                "--headset",
                "vive",
                // Noise-free (the table before issue 38): the composites' Area1 is then the
                // full frame's own pixels, checked below.
                "--shading",
                "noise-free",
                "--json",
                "--out",
                out.to_str().unwrap(),
            ]
            .map(String::from),
        );
        let o = fovea().args(&args).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let rows = v["rows"].as_array().unwrap();
        assert_eq!(rows[0]["method"], "full");
        let full = slope(&rows[0]);
        let none = rows.iter().find(|r| r["method"] == "none").unwrap();
        let err = |s: [f64; 2]| ((s[0] - full[0]).abs() + (s[1] - full[1]).abs()) / 2.0;
        let e_none = err(slope(none));
        let mut best = ("none".to_string(), e_none);
        for r in rows.iter().skip(1) {
            // Area1 (away from the boundary) is the full frame's: the smoothing stays in the
            // strip.
            let change = r["area1_change"].as_f64().unwrap();
            assert!(
                change.abs() < 0.01,
                "{name} {}: Area1 {change}",
                r["method"]
            );
            let e = err(slope(r));
            println!(
                "{name} {}: slope {:.2} / {:.2} (full {:.2} / {:.2}), error {e:.2}",
                r["method"],
                slope(r)[0],
                slope(r)[1],
                full[0],
                full[1]
            );
            if e < best.1 {
                best = (r["method"].as_str().unwrap().to_string(), e);
            }
        }
        println!(
            "{name}: best {} with slope error {:.2} against {e_none:.2} unsmoothed; relative to the full frame's |slope| {:.2}: {:.0} %",
            best.0,
            best.1,
            (full[0].abs() + full[1].abs()) / 2.0,
            100.0 * best.1 / ((full[0].abs() + full[1].abs()) / 2.0)
        );
        // Smoothing brings the slope towards the full frame's by at least a quarter of the
        // unsmoothed composite's error (measured: 0.59 and 0.68 of it, alpha blend both
        // times). The bar — within 25 % of the full frame's slope — is not reached
        // (387 % and 146 %; docs/sequences.md explains why no strip-limited smoothing can).
        assert!(best.1 < 0.75 * e_none, "{name}: {best:?} vs {e_none}");
    }
}

#[test]
fn bad_inset_options_are_one_line_errors() {
    for args in [
        vec!["inset-analysis", "--periphery-factor", "3"],
        vec!["inset-analysis", "--band", "0"],
        vec!["inset-analysis", "--inset-size", "10x10"],
        vec!["inset-analysis", "--res", "1442x1600"],
    ] {
        let o = fovea().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
}
