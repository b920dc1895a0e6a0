//! `StageWriter`'s own tests.

use super::*;

/// Files written by several threads at once are recorded in the order given, each with
/// its own bytes and hash; a path given twice is refused before anything is written.
#[test]
fn files_written_at_once_are_recorded_in_order() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("b.glint");
    let names: Vec<String> = (0..3 * FLUSHERS).map(|k| format!("m/f{k}.bin")).collect();
    let bodies: Vec<Vec<u8>> = (0..names.len()).map(|k| vec![k as u8; 1000 + k]).collect();
    let mut w = StageWriter::begin(&dir, "radiance").unwrap();
    w.write("first.json", "radiance-cameras", b"{}").unwrap();
    let files: Vec<(&str, &str, &[u8])> = names
        .iter()
        .zip(&bodies)
        .map(|(n, b)| (n.as_str(), "quadtree", b.as_slice()))
        .collect();
    w.write_many(&files).unwrap();
    let twice = [
        ("x.bin", "quadtree", &b"1"[..]),
        ("x.bin", "quadtree", &b"2"[..]),
    ];
    assert!(matches!(
        w.write_many(&twice),
        Err(BundleError::BadAssetPath { .. })
    ));
    let record = w
        .commit(StageInfo {
            scene_name: "s".into(),
            scene_hash: "h".into(),
            settings: serde_json::Value::Null,
            stats: BTreeMap::new(),
            bake_seconds: 0.0,
            force: true,
        })
        .unwrap();
    let paths: Vec<&str> = record.assets.iter().map(|a| a.path.as_str()).collect();
    let mut want = vec!["radiance/first.json".to_string()];
    want.extend(names.iter().map(|n| format!("radiance/{n}")));
    assert_eq!(paths, want);
    let bundle = super::super::Bundle::open(&dir).unwrap();
    for (a, body) in record.assets[1..].iter().zip(&bodies) {
        assert_eq!(a.blake3, blake3::hash(body).to_hex().to_string());
        assert_eq!(&bundle.read_asset(a).unwrap(), body);
    }
}
