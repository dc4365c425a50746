//! The GPU scene tables against the CPU reference's: the emitter table must hold the same
//! triangles with the same probabilities, or GPU and CPU would pick different lights.

use gi_gpu::EmitterTable;
use gi_reference::Reference;

#[test]
fn emitter_tables_match_the_reference_on_every_bundled_scene() {
    for (name, _) in gi_scene::BUNDLED_SCENES {
        let scene = gi_scene::load(name).unwrap();
        let frame = scene.evaluate(0.0, None);
        let table = EmitterTable::build(&scene, &frame);
        let reference = Reference::new(&scene, frame.clone());
        assert_eq!(
            table.entries.len(),
            reference.emissive_triangle_count(),
            "{name}"
        );
        assert_eq!(table.selection.len(), frame.triangles.len(), "{name}");
        let Some(last) = table.entries.last() else {
            continue;
        };
        // The last cdf is exactly 1: no 24-bit uniform number reaches its threshold, so every
        // draw lands in the table.
        assert_eq!(last.threshold, 1 << 24, "{name}");
        assert!(
            table
                .entries
                .windows(2)
                .all(|w| w[0].threshold <= w[1].threshold),
            "{name}: thresholds must not decrease"
        );
        let total: f64 = table.selection.iter().map(|&p| f64::from(p)).sum();
        assert!(
            (total - 1.0).abs() < 1e-5,
            "{name}: probabilities sum to {total}"
        );
        for entry in &table.entries {
            assert!(table.selection[entry.triangle as usize] > 0.0, "{name}");
        }
    }
}
