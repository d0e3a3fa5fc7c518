//! Instance, preset and result files, mutated (truncated, overwritten with random bytes, numbers
//! made huge or non-finite, nested thousands deep), are parsed to an error or to a value the
//! environment accepts — never a panic, never a hang (nextest's watchdog would end a hang).

mod support;

use std::path::Path;

use envpg_ac::presets::{BUNDLED_PRESETS, Presets};
use envpg_core::{InstanceFile, ResultFile};
use proptest::prelude::*;

const INSTANCES: [&str; 3] = [
    include_str!("../launch/instances/uav271.json"),
    include_str!("../launch/instances/flpo-n10m4.json"),
    include_str!("../launch/instances/aac1800.json"),
];
const RESULT: &str = include_str!("../results/table/runs/algorithm1_kappa0.85_s1.json");

/// Every way a file is read by envpg: the instance through the registry, the result with its
/// environment, presets merged and resolved.
fn read_everything(text: &str) {
    let registry = support::registry();
    if let Ok(file) = InstanceFile::parse(text, "<mutated>") {
        let _ = registry.build(file, &[]);
    }
    if let Ok(r) = ResultFile::from_json_str(text, "<mutated>") {
        let _ = r.load_env(&registry, "<mutated>");
    }
    if let Ok(p) = Presets::bundled().with_text(text, Path::new("<mutated>")) {
        for name in ["default", "uav", "smoke"] {
            let _ = p.get(name);
        }
    }
}

/// A text mutation.
#[derive(Debug, Clone)]
enum Mutation {
    Truncate(usize),
    Overwrite(usize, Vec<u8>),
    /// Replaces the n-th number with a hostile one.
    Number(usize, &'static str),
    /// Inserts thousands of nested brackets (JSON, or a TOML array) at a position.
    Nest(usize, bool),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..12)).prop_map(|(a, b)| Mutation::Overwrite(a, b)),
        (
            any::<usize>(),
            prop_oneof![
                Just("1e999"),
                Just("-1e999"),
                Just("NaN"),
                Just("18446744073709551616"),
                Just("-9223372036854775809"),
                Just("1e-400"),
                Just("0"),
                Just("-0.0"),
                Just("4294967296"),
                Just("1e12"),
            ]
        )
            .prop_map(|(a, b)| Mutation::Number(a, b)),
        (any::<usize>(), any::<bool>()).prop_map(|(a, b)| Mutation::Nest(a, b)),
    ]
}

fn apply(text: &str, m: &Mutation) -> String {
    let at = |i: usize| {
        let mut i = i % text.len().max(1);
        while !text.is_char_boundary(i) {
            i -= 1;
        }
        i
    };
    match m {
        Mutation::Truncate(i) => text[..at(*i)].to_owned(),
        Mutation::Overwrite(i, junk) => {
            let mut b = text.as_bytes().to_vec();
            let i = at(*i);
            for (k, x) in junk.iter().enumerate() {
                if let Some(slot) = b.get_mut(i + k) {
                    *slot = *x;
                }
            }
            String::from_utf8_lossy(&b).into_owned()
        }
        Mutation::Number(n, with) => {
            let starts: Vec<usize> = text
                .char_indices()
                .filter(|&(i, c)| {
                    (c.is_ascii_digit() || c == '-')
                        && !text[..i].ends_with(|p: char| p.is_ascii_alphanumeric() || p == '.' || p == '_')
                })
                .map(|(i, _)| i)
                .collect();
            if starts.is_empty() {
                return text.to_owned();
            }
            let s = starts[n % starts.len()];
            let len = text[s..].find(|c: char| !(c.is_ascii_digit() || "-+.eE".contains(c))).unwrap_or(text.len() - s);
            format!("{}{with}{}", &text[..s], &text[s + len..])
        }
        Mutation::Nest(i, toml) => {
            let depth = 5_000;
            let i = at(*i);
            let (open, close) = if *toml { ("a = [", "]") } else { ("[", "]") };
            format!("{}{}1{}{}", &text[..i], open.repeat(depth), close.repeat(depth), &text[i..])
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn mutated_instances_never_panic(which in 0usize..3, m in mutation()) {
        read_everything(&apply(INSTANCES[which], &m));
    }

    #[test]
    fn mutated_results_never_panic(m in mutation()) {
        read_everything(&apply(RESULT, &m));
    }

    #[test]
    fn mutated_presets_never_panic(m in mutation()) {
        read_everything(&apply(BUNDLED_PRESETS, &m));
    }
}

#[test]
fn deeply_nested_files_are_refused() {
    for text in ["[".repeat(100_000), "{\"a\":".repeat(100_000), "a = ".to_owned() + &"[".repeat(100_000)] {
        let registry = support::registry();
        assert!(InstanceFile::parse(&text, "<deep>").is_err());
        assert!(ResultFile::from_json_str(&text, "<deep>").is_err());
        assert!(Presets::bundled().with_text(&text, Path::new("<deep>")).is_err());
        drop(registry);
    }
}
