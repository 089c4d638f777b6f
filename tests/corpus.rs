//! The loader corpus: every file of `tests/data/manifest.json` (made by
//! `tests/data/make_test_data.py`) is loaded with `caustic info --json` and rendered at
//! 8×8, 1 spp; good files must give the stated counts, bounds, warnings and pixel
//! checks, bad files a clear error with the stated exit code, no output and no panic.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

mod common;

use common::{root, run, temp_dir};
use serde_json::Value;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(60);

fn lower_contains(haystack: &str, needle: &str) -> bool {
    haystack.to_lowercase().contains(&needle.to_lowercase())
}

fn check_ok(entry: &Value, path: &str, failures: &mut Vec<String>) {
    let file = entry["file"].as_str().unwrap();
    let info = run(&["info", path, "--json"], LIMIT);
    if info.code != Some(0) {
        failures.push(format!("{file}: info exited {:?}: {}", info.code, info.stderr.trim()));
        return;
    }
    let v: Value = match serde_json::from_str(&info.stdout) {
        Ok(v) => v,
        Err(e) => {
            failures.push(format!("{file}: info --json is not JSON: {e}"));
            return;
        }
    };
    let mut expect_eq = |what: &str, got: &Value, want: &Value| {
        if !want.is_null() && got != want {
            failures.push(format!("{file}: {what} is {got}, expected {want}"));
        }
    };
    expect_eq("triangles", &v["triangles"], &entry["triangles"]);
    expect_eq("punctual lights", &v["punctual_lights"], &entry["lights"]["punctual"]);
    expect_eq("emissive triangles", &v["emissive_triangles"], &entry["lights"]["emissive_triangles"]);
    let file_cameras =
        v["cameras"].as_array().map(|c| c.iter().filter(|c| c["generated"] == false).count()).unwrap_or(0);
    expect_eq("cameras", &Value::from(file_cameras), &entry["cameras"]);
    if let Some(b) = entry.get("bounds") {
        for (k, key) in [(0usize, "min"), (1, "max")] {
            for axis in 0..3 {
                let want = b[key][axis].as_f64().unwrap();
                let got = v["bounds"][k][axis].as_f64().unwrap_or(f64::NAN);
                if !((got - want).abs() <= 1e-4 * (1.0 + want.abs())) {
                    failures.push(format!("{file}: bounds {key}[{axis}] = {got}, expected {want}"));
                }
            }
        }
    }
    let warnings: Vec<String> = v["warnings"]
        .as_array()
        .map(|w| w.iter().filter_map(|s| s.as_str().map(str::to_string)).collect())
        .unwrap_or_default();
    for w in entry["warnings_contain"].as_array().into_iter().flatten() {
        let w = w.as_str().unwrap();
        if !warnings.iter().any(|x| lower_contains(x, w)) {
            failures.push(format!("{file}: no warning containing '{w}' (warnings: {warnings:?})"));
        }
    }

    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let out_s = out.to_str().unwrap();
    let r = run(&["render", path, "-o", out_s, "--resolution", "8x8", "--spp", "1", "--progress", "json"], LIMIT);
    if r.code != Some(0) {
        failures.push(format!("{file}: render exited {:?}: {}", r.code, r.stderr.trim()));
        return;
    }
    if r.stderr.contains("panicked") {
        failures.push(format!("{file}: render panicked"));
    }
    let Ok((w, h, px)) = caustic::output::read_combined(&out) else {
        failures.push(format!("{file}: output EXR unreadable"));
        return;
    };
    assert_eq!((w, h), (8, 8));
    for check in entry["render_checks"].as_array().into_iter().flatten() {
        let reg: Vec<usize> =
            check["region"].as_array().unwrap().iter().map(|x| x.as_u64().unwrap() as usize).collect();
        let mut mean = [0f64; 4];
        let mut n = 0.0;
        for y in reg[1]..reg[3] {
            for x in reg[0]..reg[2] {
                for c in 0..4 {
                    mean[c] += px[y * w + x][c] as f64;
                }
                n += 1.0;
            }
        }
        for m in &mut mean {
            *m /= n;
        }
        let what = check["what"].as_str().unwrap_or("");
        for c in 0..3 {
            if let Some(lo) = check["rgb_min"].get(c).and_then(Value::as_f64)
                && mean[c] < lo
            {
                failures.push(format!("{file}: {what}: channel {c} mean {} < {lo}", mean[c]));
            }
            if let Some(hi) = check["rgb_max"].get(c).and_then(Value::as_f64)
                && mean[c] > hi
            {
                failures.push(format!("{file}: {what}: channel {c} mean {} > {hi}", mean[c]));
            }
        }
        if let Some(a) = check["alpha_min"].as_f64()
            && mean[3] < a
        {
            failures.push(format!("{file}: {what}: alpha {} < {a}", mean[3]));
        }
        if let Some(a) = check["alpha_max"].as_f64()
            && mean[3] > a
        {
            failures.push(format!("{file}: {what}: alpha {} > {a}", mean[3]));
        }
    }
}

fn check_error(entry: &Value, path: &str, failures: &mut Vec<String>) {
    let file = entry["file"].as_str().unwrap();
    let want_code = entry["exit_code"].as_i64().unwrap() as i32;
    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let r = run(
        &["render", path, "-o", out.to_str().unwrap(), "--resolution", "8x8", "--spp", "1", "--progress", "json"],
        LIMIT,
    );
    if r.code != Some(want_code) {
        failures.push(format!("{file}: exit {:?}, expected {want_code}: {}", r.code, r.stderr.trim()));
    }
    if r.stderr.contains("panicked") {
        failures.push(format!("{file}: panicked: {}", r.stderr.trim()));
    }
    if out.exists() || std::fs::read_dir(dir.path()).map(|d| d.count()).unwrap_or(0) > 0 {
        failures.push(format!("{file}: left a file behind after an error"));
    }
    let Some(msg) = r.error_message() else {
        failures.push(format!("{file}: no JSON error object: {}", r.stderr.trim()));
        return;
    };
    for s in entry["message_contains"].as_array().into_iter().flatten() {
        let s = s.as_str().unwrap();
        if !lower_contains(&msg, s) {
            failures.push(format!("{file}: message '{msg}' lacks '{s}'"));
        }
    }
    if let Some(any) = entry["message_contains_any"].as_array()
        && !any.is_empty()
        && !any.iter().any(|s| lower_contains(&msg, s.as_str().unwrap()))
    {
        failures.push(format!("{file}: message '{msg}' contains none of {any:?}"));
    }
    // `info` must refuse the file the same way.
    let i = run(&["info", path], LIMIT);
    if i.code != Some(want_code) {
        failures.push(format!("{file}: info exit {:?}, expected {want_code}", i.code));
    }
}

#[test]
fn manifest_corpus() {
    let data = root().join("tests/data");
    let manifest: Vec<Value> = serde_json::from_slice(&std::fs::read(data.join("manifest.json")).unwrap()).unwrap();
    assert!(manifest.len() >= 40, "the corpus shrank");
    let mut failures = Vec::new();
    for entry in &manifest {
        let path = data.join(entry["file"].as_str().unwrap());
        let path_s = path.to_str().unwrap();
        match entry["expect"].as_str().unwrap() {
            "ok" => check_ok(entry, path_s, &mut failures),
            "error" => check_error(entry, path_s, &mut failures),
            other => panic!("unknown expectation {other}"),
        }
    }
    assert!(failures.is_empty(), "{} problem(s):\n{}", failures.len(), failures.join("\n"));
}
