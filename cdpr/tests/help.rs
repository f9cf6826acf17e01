//! The method names in the help and in `cdpr/README.md` come from
//! `tension_core::Method::ALL`, so that a new method shows up by itself.

mod common;

use std::path::PathBuf;

use common::*;
use tension_core::Method;

const BEGIN: &str = "<!-- methods: from tension_core::Method::ALL; tests/help.rs checks this list, CDPR_BLESS=1 rewrites it -->\n";
const END: &str = "<!-- end of methods -->\n";

/// The README's method table: every method and the cables it needs
/// (`m = n + 2` for the methods that work on the polygon of `r = 2`).
fn method_table() -> String {
    let mut table = String::from("| method | cables |\n| --- | --- |\n");
    for method in Method::ALL {
        // Every shape with `m >= n` except `r = 2` rules a method out.
        let cables = if method.supports(6, 9) { "m >= n" } else { "m = n + 2" };
        table.push_str(&format!("| `{}` | `{cables}` |\n", method.name()));
    }
    table
}

#[test]
fn help_lists_every_method() {
    let dir = scratch("help");
    for command in ["solve", "trajectory", "workspace"] {
        let run = cdpr_ok(&dir, &[command, "--help"]);
        for method in Method::ALL {
            assert!(run.stdout.contains(method.name()), "cdpr {command} --help lacks {}", method.name());
        }
    }
}

#[test]
fn readme_lists_every_method() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let start = text.find(BEGIN).expect("README has the methods block") + BEGIN.len();
    let end = start + text[start..].find(END).expect("README's methods block ends");
    let want = method_table();
    if text[start..end] != want && std::env::var_os("CDPR_BLESS").is_some() {
        std::fs::write(&path, format!("{}{want}{}", &text[..start], &text[end..])).unwrap();
        return;
    }
    assert_eq!(text[start..end], want, "cdpr/README.md's method table is stale: run with CDPR_BLESS=1");
}
