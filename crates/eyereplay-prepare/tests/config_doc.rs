//! docs/CONFIG.md stays true to the config: every TOML example in it parses
//! and validates, and every key the config serializes is documented.

use eyereplay_prepare::DatasetConfig;

fn doc() -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/CONFIG.md");
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

const ONE_CLASS: &str =
    "[classes.reading]\nsources = [{ format = \"extract\", path = \"a.csv\" }]\n";

#[test]
fn every_toml_example_parses_and_validates() {
    let text = doc();
    let blocks: Vec<&str> = text
        .split("```toml\n")
        .skip(1)
        .map(|b| b.split("```").next().unwrap())
        .collect();
    assert!(blocks.len() >= 10, "{} blocks", blocks.len());
    for b in blocks {
        // A fragment without a class gets one, after its own tables; a
        // top-level fragment must stay before any table.
        let full = if b.contains("[classes.") {
            b.to_string()
        } else {
            format!("{b}\n{ONE_CLASS}")
        };
        let cfg = DatasetConfig::parse(&full).unwrap_or_else(|e| panic!("{e}\n{b}"));
        cfg.validate().unwrap_or_else(|e| panic!("{e}\n{b}"));
    }
}

#[test]
fn every_config_key_is_documented() {
    let text = doc();
    let cfg = DatasetConfig::parse(ONE_CLASS).unwrap();
    let value = toml::Value::try_from(&cfg).unwrap();
    let mut missing = Vec::new();
    fn walk(v: &toml::Value, text: &str, missing: &mut Vec<String>) {
        if let toml::Value::Table(t) = v {
            for (k, v) in t {
                // Class names and source entries are values, not keys.
                if k == "reading" || k == "conversation" {
                    continue;
                }
                if !text.contains(&format!("`{k}`")) && !text.contains(&format!(".{k}`")) {
                    missing.push(k.clone());
                }
                walk(v, text, missing);
            }
        }
    }
    walk(&value, &text, &mut missing);
    assert!(missing.is_empty(), "undocumented keys: {missing:?}");
}
