//! Every Zenoh configuration shipped in `pipeline/deploy/` (the router's, the clients', and the
//! mutual-TLS deployment's) is one Zenoh reads, and bounds the largest message a peer may send
//! to cellsar's own limit (`bridge::zconfig::DEFAULT_MAX_MESSAGE_BYTES`), not Zenoh's 1 GiB,
//! both as cellsar reads it (`-c FILE`) and as the file states it (for `zenohd -c FILE`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use harness::root;

#[test]
fn every_shipped_configuration_bounds_the_message_size() {
    let dir = root().join("pipeline/deploy");
    let mut files: Vec<_> = ["", "tls"]
        .iter()
        .flat_map(|sub| std::fs::read_dir(dir.join(sub)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json5"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 8, "{files:?}");
    let want = bridge::zconfig::DEFAULT_MAX_MESSAGE_BYTES.to_string();
    for f in &files {
        let args = bridge::ZenohArgs {
            config: Some(f.clone()),
            ..Default::default()
        };
        let config = args
            .to_config()
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let got = config
            .get_json(bridge::zconfig::MAX_MESSAGE_SIZE_KEY)
            .unwrap();
        assert_eq!(got, want, "{}", f.display());
        // the file itself states it (zenohd reads it as it is)
        let text = std::fs::read_to_string(f).unwrap();
        assert!(
            text.contains(&format!("max_message_size: {want}")),
            "{} does not state max_message_size",
            f.display()
        );
    }
}
