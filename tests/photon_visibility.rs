//! Cast Shadow off and Ray Visibility in Jensen's photon mapping and SPPM
//! (`src/integrator/photon/visibility.rs`, `src/integrator/linking.rs`): both converge to
//! the path tracer's image, region by region, and neither warns that it ignores the rule.
//!
//! The scene (`common::visibility_cases`): a grey floor, a back wall and a grey quad hanging
//! over the floor ("Blocker"), seen from the front, lit by a point light above the blocker,
//! with indirect light (max depth 4). Each case changes one rule: the light's Cast Shadow off (the floor
//! under the blocker is lit directly, and so is the blocker's top: photons pass the blocker
//! and scatter at both), the blocker hidden from diffuse rays (it still casts its direct
//! shadow, but the floor's and the wall's diffuse rays pass it, and its own bounce light
//! reaches them only through their glossy layer), the blocker seen by shadow rays alone, or
//! the light hidden from diffuse rays (it lights only the materials' glossy layer). A point light is a
//! delta light, which the path tracer takes by next-event estimation alone with weight 1,
//! so its image is the reference without MIS shares in the way. Each case checks that its
//! rule matters: the path tracer's image without it leaves the case's bounds.
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test. The photon integrators are consistent, not
//! unbiased: their kernel blurs the indirect light by at most the gather radius, which the
//! test sets to 0.02 on a scene 4 units across, as `tests/linking_integrators.rs` derives:
//! the blur's loss at the edges is a tenth of the regions' noise bound.

mod common;

use common::agreement::{Seeded, disagreeing, regions, sidak};
use common::visibility_cases::{cases, scene};
use common::{quick_render_warnings, temp_dir};
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);

/// Jensen and SPPM each agree with the path tracer on every case, and each case's rule
/// matters.
#[test]
fn photon_integrators_match_the_path_tracer() {
    let dir = temp_dir();
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded {
        dir: dir.path(),
        common: vec!["--resolution", &r, "--max-depth", "4"],
        seeds: 6,
        regions: &regs,
        limit: LIMIT,
    };
    let means = |path: &Path, extra: &[&str]| seeded.means(path, extra);
    let cases = cases();
    let alpha = sidak(regs.len() * 3 * cases.len());
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let plain = means(&scene(dir.path(), "plain.gltf", &cases[0].without_rule()), &path_tracer);
    let mut failed = Vec::new();
    for (k, case) in cases.iter().enumerate() {
        let ruled = scene(dir.path(), &format!("case{k}.gltf"), case);
        let reference = means(&ruled, &path_tracer);
        let label = format!("{}: without the rule", case.name);
        assert!(!disagreeing(&label, &regs, &plain, &reference, alpha).is_empty(), "{label}: it changes nothing");
        let others: [(&str, &[&str]); 2] = [
            ("photon", &["--integrator", "photon", "--spp", "32", "--photons", "400000", "--max-radius", "0.02"]),
            ("sppm", &["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-radius", "0.02"]),
        ];
        let case_failed = seeded.disagreeing_others(&ruled, &reference, &others, alpha);
        failed.extend(case_failed.into_iter().map(|r| format!("{}: {r}", case.name)));
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// Neither photon integrator warns that it ignores a case's rule.
#[test]
fn no_photon_integrator_warns_about_the_rules() {
    let dir = temp_dir();
    for (k, case) in cases().iter().enumerate() {
        let path = scene(dir.path(), &format!("w{k}.gltf"), case);
        for integrator in ["photon", "sppm"] {
            let out = dir.path().join(format!("{integrator}.exr"));
            let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
            let warned: Vec<String> = quick_render_warnings(&path, &out, &flags, LIMIT)
                .into_iter()
                .filter(|m| m.contains("Cast Shadow") || m.contains("ray visibility") || m.contains("shadow catcher"))
                .collect();
            assert!(warned.is_empty(), "{} / {integrator}: {warned:?}", case.name);
        }
    }
}
