//! The committed C header is what cbindgen generates from `src/lib.rs` with `cbindgen.toml`
//! (CI runs this test, so a stale header fails it). `TANDEM_BLESS=1` rewrites the header.

use std::path::Path;

#[test]
fn header_is_up_to_date() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).unwrap();
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/lib.rs"))
        .generate()
        .expect("cbindgen generates the header")
        .write(&mut generated);
    let generated = String::from_utf8(generated).unwrap();
    let path = dir.join("include/tandem.h");
    if std::env::var_os("TANDEM_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/tandem.h is stale: regenerate it with \
         `TANDEM_BLESS=1 cargo test --release -p tandem-ffi --test header` and commit it"
    );
}

/// Every exported function of the crate is declared in the header (a guard on the generator's
/// configuration: a function cbindgen skipped would otherwise go unnoticed).
#[test]
fn header_declares_every_export() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(dir.join("src/lib.rs")).unwrap();
    let header = std::fs::read_to_string(dir.join("include/tandem.h")).unwrap();
    let mut n = 0;
    for line in src.lines() {
        if let Some(rest) = line.trim().strip_prefix("pub extern \"C\" fn ") {
            let name = &rest[..rest.find('(').unwrap()];
            assert!(
                header.contains(&format!("{name}(")),
                "{name} is not declared in include/tandem.h"
            );
            n += 1;
        }
    }
    assert!(n >= 15, "found only {n} exported functions");
}
