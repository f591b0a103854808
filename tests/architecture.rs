//! The layers hold (docs/architecture.md): the core crate depends on no command-line, plotting or
//! signal crate, the presentation crate on no command-line or signal crate, and no source file
//! of any crate is part of a dependency cycle with another.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "common/tree.rs"]
mod tree;

/// The output of `cargo tree ARGS --prefix none` on this workspace. Not `--offline`: on a new
/// machine the Python extension's crates (PyO3, numpy) are not downloaded before its build,
/// and cargo fetches what the tree needs from the registry as any build would.
fn cargo_tree(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO"))
        .arg("tree")
        .args(args)
        .args(["--prefix", "none", "--locked"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The packages `package` depends on at run time (`cargo tree -e normal`), by name.
fn runtime_dependencies(package: &str) -> BTreeSet<String> {
    cargo_tree(&["-p", package, "-e", "normal", "--format", "{p}"])
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .collect()
}

/// `cargo tree` with `args`, one line a package: "name version features".
fn tree_lines(args: &[&str]) -> BTreeSet<String> {
    let mut all = args.to_vec();
    all.extend(["--format", "{p} {f}"]);
    cargo_tree(&all)
        .lines()
        .map(|l| l.trim_end_matches(" (*)").to_string())
        // drop the path a workspace member shows between its version and its features
        .map(|l| match (l.find(" ("), l.rfind(") ")) {
            (Some(a), Some(b)) if a < b => format!("{}{}", &l[..a], &l[b + 1..]),
            _ => l,
        })
        .collect()
}

/// The feature sets the dependencies of `lines` are compiled with, by "name version".
fn feature_sets(lines: &BTreeSet<String>) -> BTreeMap<String, BTreeSet<String>> {
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for l in lines {
        let mut parts = l.splitn(3, ' ');
        let (name, version) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
        let features = parts.next().unwrap_or("").trim().to_string();
        out.entry(format!("{name} {version}"))
            .or_default()
            .insert(features);
    }
    out
}

/// The Python extension's build (maturin, `python/` alone) asks for every shared dependency
/// with the features the test build compiled it with, so it reuses those units instead of
/// recompiling the core (crates/unify; docs/architecture.md#build-times).
#[test]
fn the_python_build_reuses_the_test_builds_dependencies() {
    let python = feature_sets(&tree_lines(&["-p", "pumpcyl-python", "-e", "normal,build"]));
    let tests = feature_sets(&tree_lines(&["-e", "normal,build,dev"]));
    let differ: Vec<String> = python
        .iter()
        .filter_map(|(package, features)| {
            let theirs = tests.get(package)?;
            (theirs != features)
                .then(|| format!("{package}: python {features:?}, tests {theirs:?}"))
        })
        .collect();
    assert!(
        differ.is_empty(),
        "add these features to crates/unify/Cargo.toml: {differ:#?}"
    );
    // the check sees the shared dependencies at all
    assert!(python.contains_key("nalgebra v0.35.0") && tests.contains_key("nalgebra v0.35.0"));
}

/// The binary's build and the Python extension's each ask for every dependency with one
/// feature set, whether it is built for a build script (the host side) or for the program:
/// the core that crates/fmu-binary's build script links the FMU's library against is then the
/// very unit the binary links, compiled once (crates/unify; docs/architecture.md#build-times).
#[test]
fn build_scripts_and_programs_share_one_feature_set_of_each_dependency() {
    for args in [
        &["-e", "normal,build"][..],
        &["-p", "pumpcyl-python", "-e", "normal,build"][..],
    ] {
        let split: Vec<String> = feature_sets(&tree_lines(args))
            .into_iter()
            .filter(|(_, features)| features.len() > 1)
            .map(|(package, features)| format!("{package}: {features:?}"))
            .collect();
        assert!(
            split.is_empty(),
            "cargo tree {args:?}: add the larger feature set to crates/unify/Cargo.toml: {split:#?}"
        );
    }
    // the core is a build dependency at all, so the check is about something
    let fmu = cargo_tree(&["-p", "pumpcyl-fmu-binary", "-e", "build", "--depth", "1"]);
    assert!(fmu.lines().any(|l| l.starts_with("pumpcyl v")), "{fmu}");
}

#[test]
fn the_core_needs_no_front_end_crate_and_present_no_command_line_crate() {
    let core = runtime_dependencies("pumpcyl");
    for banned in [
        "clap",
        "indicatif",
        "signal-hook",
        "plotters",
        "resvg",
        "tempfile",
    ] {
        assert!(!core.contains(banned), "the core depends on {banned}");
    }
    assert!(core.contains("nalgebra"), "{core:?}");
    let present = runtime_dependencies("pumpcyl-present");
    for banned in ["clap", "indicatif", "signal-hook"] {
        assert!(
            !present.contains(banned),
            "pumpcyl-present depends on {banned}"
        );
    }
    assert!(present.contains("plotters") && present.contains("pumpcyl"));
}

/// Every `.rs` file under `dir`, by its path relative to `dir`.
fn sources(dir: &Path) -> BTreeMap<String, String> {
    tree::files(dir)
        .into_iter()
        .filter(|rel| rel.ends_with(".rs"))
        .map(|rel| {
            let text = std::fs::read_to_string(dir.join(&rel)).unwrap();
            (rel.replace('\\', "/"), text)
        })
        .collect()
}

/// The module path of a source file (`lti/mod.rs` → [lti], `lti/poles.rs` → [lti, poles]).
fn module_of(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(String::from)
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The code of a file without its tests and comments.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The paths (`crate::a::b::C`, `super::d::E`, the items of a `{…}` group) a file names, as
/// module paths from the crate root.
fn named_paths(module: &[String], text: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut i = 0;
    while i < bytes.len() {
        if !text.is_char_boundary(i) {
            i += 1;
            continue;
        }
        let rest = &text[i..];
        let base = ["crate::", "super::"]
            .into_iter()
            .find(|b| rest.starts_with(b));
        if base.is_none() || (i > 0 && ident(bytes[i - 1])) {
            i += 1;
            continue;
        }
        let mut end = i;
        while end < bytes.len() && (ident(bytes[end]) || bytes[end] == b':') {
            end += 1;
        }
        let mut segs: Vec<String> = text[i..end]
            .split("::")
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        let mut prefix: Vec<String> = Vec::new();
        if segs[0] == "super" {
            // `super` of a mod.rs file's module is its parent, as for any file
            prefix = module[..module.len().saturating_sub(1)].to_vec();
            segs.remove(0);
            while segs.first().is_some_and(|s| s == "super") {
                prefix.pop();
                segs.remove(0);
            }
        } else {
            segs.remove(0);
        }
        let head: Vec<String> = prefix.into_iter().chain(segs).collect();
        out.push(head.clone());
        if text[end..].starts_with('{') {
            let close = text[end..].find('}').map_or(text.len(), |k| end + k);
            for item in text[end + 1..close].split(',') {
                let item: Vec<String> = item
                    .trim()
                    .split("::")
                    .map(|s| s.split_whitespace().next().unwrap_or("").to_string())
                    .filter(|s| !s.is_empty() && s != "self")
                    .collect();
                out.push(head.iter().cloned().chain(item).collect());
            }
        }
        i = end.max(i + 1);
    }
    out
}

/// The files of `src` that lie on a dependency cycle, each with its edges inside the cycle.
fn cycles(src: &Path) -> Vec<BTreeSet<String>> {
    let files = sources(src);
    let by_module: BTreeMap<Vec<String>, String> =
        files.keys().map(|f| (module_of(f), f.clone())).collect();
    // `pub use child::{A, B}` in a module: A and B are defined in the child
    let mut reexports: BTreeMap<(Vec<String>, String), Vec<String>> = BTreeMap::new();
    for (f, text) in &files {
        let m = module_of(f);
        for line in code(text).lines() {
            let Some(rest) = line.trim().strip_prefix("pub use ") else {
                continue;
            };
            let rest = rest.trim_start_matches("self::");
            let Some((child, items)) = rest.split_once("::") else {
                continue;
            };
            if !by_module.contains_key(&[m.clone(), vec![child.to_string()]].concat()) {
                continue;
            }
            for item in items
                .split([',', '{', '}', ';', ' '])
                .filter(|s| !s.is_empty())
            {
                let target = [m.clone(), vec![child.to_string()]].concat();
                reexports.insert((m.clone(), item.to_string()), target);
            }
        }
    }
    let resolve = |path: &[String]| -> Option<String> {
        let mut path = path.to_vec();
        for _ in 0..8 {
            let k = (0..=path.len())
                .rev()
                .find(|&k| by_module.contains_key(&path[..k]))?;
            let module = path[..k].to_vec();
            match path
                .get(k)
                .and_then(|item| reexports.get(&(module.clone(), item.clone())))
            {
                Some(target) if *target != module => {
                    path = target
                        .iter()
                        .cloned()
                        .chain(path[k + 1..].iter().cloned())
                        .collect()
                }
                _ => return by_module.get(&module).cloned(),
            }
        }
        None
    };
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (f, text) in &files {
        for p in named_paths(&module_of(f), &code(text)) {
            if let Some(g) = resolve(&p).filter(|g| g != f) {
                edges.entry(f.clone()).or_default().insert(g);
            }
        }
    }
    // files that reach each other lie on a cycle
    let reach = |from: &String| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(v) = stack.pop() {
            for w in edges.get(&v).into_iter().flatten() {
                if seen.insert(w.clone()) {
                    stack.push(w.clone());
                }
            }
        }
        seen
    };
    let reaches: BTreeMap<String, BTreeSet<String>> =
        files.keys().map(|f| (f.clone(), reach(f))).collect();
    let mut out: Vec<BTreeSet<String>> = Vec::new();
    for f in files.keys() {
        let comp: BTreeSet<String> = reaches[f]
            .iter()
            .filter(|g| reaches[*g].contains(f))
            .cloned()
            .collect();
        if !comp.is_empty() && !out.iter().any(|c| c.contains(f)) {
            out.push(comp);
        }
    }
    out
}

#[test]
fn no_source_file_is_on_a_dependency_cycle() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for src in ["crates/core/src", "crates/present/src", "src", "python/src"] {
        let found = cycles(&root.join(src));
        assert!(found.is_empty(), "{src}: files on a cycle: {found:?}");
    }
}

#[test]
fn the_cycle_check_finds_a_cycle() {
    let dir = tempfile::tempdir().unwrap();
    let src: PathBuf = dir.path().into();
    std::fs::create_dir(src.join("a")).unwrap();
    std::fs::write(src.join("lib.rs"), "mod a;\nmod b;\n").unwrap();
    std::fs::write(src.join("a/mod.rs"), "mod x;\npub use x::X;\n").unwrap();
    std::fs::write(src.join("a/x.rs"), "use crate::b::Y;\npub struct X;\n").unwrap();
    std::fs::write(src.join("b.rs"), "use crate::a::X;\npub struct Y;\n").unwrap();
    let found = cycles(&src);
    let want: BTreeSet<String> = ["a/x.rs", "b.rs"].map(String::from).into();
    assert_eq!(found, vec![want]);
}

/// The code of a Rust file as the compiler's tokens see it: comments, string and character
/// literals blanked (a record column named in a string, `"p2_bar"`, is no identifier), and
/// everything from its test module (`#[cfg(test)]`) on left out.
fn code_only(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            i += 2;
            while i + 1 < c.len() && !(c[i] == '*' && c[i + 1] == '/') {
                i += 1;
            }
            i += 2;
            out.push(' ');
        } else if (c[i] == 'r' || c[i] == 'b')
            && (i == 0 || !ident(c[i - 1]))
            && matches!(next, Some('"') | Some('#') | Some('r'))
            && c[i..].iter().skip(1).find(|ch| **ch != '#' && **ch != 'r') == Some(&'"')
            && (c[i] == 'r' || next != Some('#'))
        {
            // a raw (or byte) string: r"…", r#"…"#, br"…"
            let start = c[i..].iter().position(|ch| *ch == '"').unwrap() + i;
            let hashes = c[i..start].iter().filter(|ch| **ch == '#').count();
            let raw = c[i..start].contains(&'r');
            i = start + 1;
            while i < c.len() {
                if !raw && c[i] == '\\' {
                    i += 2;
                    continue;
                }
                if c[i] == '"'
                    && c[i + 1..]
                        .iter()
                        .take(hashes)
                        .filter(|ch| **ch == '#')
                        .count()
                        == hashes
                {
                    i += 1 + hashes;
                    break;
                }
                i += 1;
            }
            out.push_str("\"\"");
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if c[i] == '\'' && next == Some('\\') {
            // an escaped character literal, '\n', '\u{…}'
            i += 2;
            while i < c.len() && c[i] != '\'' {
                i += 1;
            }
            i += 1;
            out.push_str("' '");
        } else if c[i] == '\'' && c.get(i + 2) == Some(&'\'') {
            i += 3;
            out.push_str("' '");
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// Names only a circuit module may use: the DPM's fixed state layout and its two-motor
/// signal names. Identifiers are matched whole (`LegendLayout` and `p2_bar` are other names);
/// the patterns that start with `.` or hold `[` are matched as written.
const CIRCUIT_ONLY: [&str; 12] = [
    "Layout",
    "SIM_OUTPUTS",
    "p2",
    "w2",
    "omega2",
    ".layout",
    "layout()",
    "layout.p[",
    "layout.w[",
    "l.p[",
    "l.w[",
    ".tau",
];

/// Where `code` uses a name of [`CIRCUIT_ONLY`]: (line, name).
fn circuit_names(code: &str) -> Vec<(usize, &'static str)> {
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut out = Vec::new();
    for (n, line) in code.lines().enumerate() {
        for name in CIRCUIT_ONLY {
            let hit = line.match_indices(name).any(|(k, _)| {
                let before = line[..k].chars().next_back();
                let after = line[k + name.len()..].chars().next();
                let starts_word = name.starts_with(|ch: char| ident(ch));
                let ends_word = name.ends_with(|ch: char| ident(ch));
                let glued_before = starts_word && before.is_some_and(ident);
                let glued_after = ends_word && after.is_some_and(ident);
                !glued_before && !glued_after
            });
            if hit {
                out.push((n + 1, name));
            }
        }
    }
    out
}

/// Names a file outside the circuits may still use: the rig file's own checks of the DPM's
/// rest pressures (its keys are the DPM's, docs/formats.md#rig-toml) until the rig keys move
/// into the circuits.
const ALLOWED: [(&str, &str); 1] = [("crates/core/src/rig.rs", "p2")];

/// What `check` finds in the code ([`code_only`]) of every source file of every crate outside
/// `crates/core/src/circuit/`, given the file's path from the workspace root: "path:line: what".
fn outside_the_circuits(check: impl Fn(&str, &str) -> Vec<(usize, String)>) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = Vec::new();
    for src in [
        "crates/core/src",
        "crates/present/src",
        "crates/fmu/src",
        "crates/fmu-binary/src",
        "src",
        "python/src",
    ] {
        for (rel, text) in sources(&root.join(src)) {
            let path = format!("{src}/{rel}");
            if path.starts_with("crates/core/src/circuit/") {
                continue;
            }
            for (line, what) in check(&path, &code_only(&text)) {
                found.push(format!("{path}:{line}: {what}"));
            }
        }
    }
    found
}

/// Outside `crates/core/src/circuit/`, no code names a circuit's states by the DPM's layout or
/// its signal names: everything works through the circuit's named signals (docs/architecture.md).
#[test]
fn only_a_circuit_names_its_states() {
    let found = outside_the_circuits(|path, code| {
        (circuit_names(code).into_iter())
            .filter(|(_, name)| !ALLOWED.contains(&(path, *name)))
            .map(|(line, name)| (line, name.to_string()))
            .collect()
    });
    assert!(
        found.is_empty(),
        "names a circuit's states:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_name_check_sees_code_and_not_strings_or_comments() {
    let text = "// p2 in a comment\nlet p2 = x[plant.layout.p[1]]; let s = \"p2_bar w2\";\n\
                let r = r#\"omega2 \"quoted\"\"#; let c = '\\''; let t = d.tau; let u = d.tau_ff;\n\
                struct LegendLayout; let w2_rpm = 1; fn f<'a>(x: &'a SIM_OUTPUTS) {}\n\
                #[cfg(test)]\nmod tests { let w2 = 0; }";
    let code = code_only(text);
    let names: Vec<&str> = circuit_names(&code).into_iter().map(|(_, n)| n).collect();
    assert_eq!(
        names,
        ["p2", ".layout", "layout.p[", ".tau", "SIM_OUTPUTS"],
        "{code}"
    );
}

/// The enums made from the list of circuits (crates/core/src/circuit/mod.rs), whose variants
/// are the circuits (the emulated form's enum shares its name, `Emulated`, with the records'
/// and is used outside the circuits through its methods only).
const CIRCUIT_ENUMS: [&str; 2] = ["CircuitKind", "AnyCircuit"];

/// Where `code` names a circuit by its variant (`CircuitKind::Dpm`, `AnyCircuit::SinglePump(…)`):
/// (line, the path named). Constants (`CircuitKind::ALL`) and methods (`CircuitKind::name`)
/// are not variants: a variant's name is in camel case.
fn circuit_variants(code: &str) -> Vec<(usize, String)> {
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut out = Vec::new();
    for (n, line) in code.lines().enumerate() {
        for name in CIRCUIT_ENUMS {
            for (k, _) in line.match_indices(&format!("{name}::")) {
                if line[..k].chars().next_back().is_some_and(ident) {
                    continue;
                }
                let rest = &line[k + name.len() + 2..];
                let tail: String = rest
                    .chars()
                    .take_while(|&ch| ident(ch) || ch == '{')
                    .collect();
                let camel = |w: &str| {
                    w.starts_with(|ch: char| ch.is_ascii_uppercase())
                        && w.chars().any(|ch| ch.is_ascii_lowercase())
                };
                if tail.trim_start_matches('{').split(['{', ',']).any(camel) {
                    out.push((n + 1, format!("{name}::{tail}")));
                }
            }
        }
    }
    out
}

/// Outside `crates/core/src/circuit/`, no code (tests apart) names a circuit by its variant:
/// everything asks a circuit's description or its module's forms, so that a circuit is added
/// in its module and the list alone (docs/architecture.md#circuits).
#[test]
fn only_the_list_of_circuits_names_them() {
    let found = outside_the_circuits(|_, code| circuit_variants(code));
    assert!(found.is_empty(), "names a circuit:\n{}", found.join("\n"));
}

#[test]
fn the_circuit_check_sees_variants_and_not_constants_or_methods() {
    let text = "let k = CircuitKind::SinglePump; for k in CircuitKind::ALL {}\n\
                let n = CircuitKind::name(k); if let AnyCircuit::Dpm(d) = c {}\n\
                use crate::circuit::CircuitKind::{Dpm, DualPump}; let s = \"CircuitKind::Dpm\";\n\
                let e = MyCircuitKind::Dpm;\n\
                #[cfg(test)]\nmod tests { let k = CircuitKind::Dpm; }";
    let found: Vec<(usize, String)> = circuit_variants(&code_only(text));
    let want = [
        (1, "CircuitKind::SinglePump"),
        (2, "AnyCircuit::Dpm"),
        (3, "CircuitKind::{Dpm"),
    ];
    let want: Vec<(usize, String)> = want.iter().map(|(l, s)| (*l, s.to_string())).collect();
    assert_eq!(found, want);
}

/// The functions of `text` longer than `limit` lines, each `name (N lines)`: a function runs
/// from its `fn` line to the closing brace at the `fn` line's indent (rustfmt's layout).
fn long_functions(text: &str, limit: usize) -> Vec<String> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        let indent = &line[..line.len() - line.trim_start().len()];
        let rest = line.trim_start();
        let rest = rest
            .strip_prefix("pub ")
            .or_else(|| rest.strip_prefix("pub(crate) "))
            .unwrap_or(rest);
        let Some(name) = rest
            .strip_prefix("fn ")
            .map(|r| r.split(['(', '<']).next().unwrap_or(r))
        else {
            i += 1;
            continue;
        };
        let end = (i + 1..lines.len()).find(|&j| lines[j] == format!("{indent}}}"));
        let Some(end) = end else {
            i += 1;
            continue;
        };
        if end - i + 1 > limit {
            out.push(format!("{name} ({} lines)", end - i + 1));
        }
        i = end + 1;
    }
    out
}

/// Each command is a request and one call (docs/architecture.md#requests): no function of the
/// requests, of the command line or of the Python module is over 80 lines.
#[test]
fn the_request_paths_are_short() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = Vec::new();
    for dir in ["crates/present/src/request", "src", "python/src"] {
        for (rel, text) in sources(&root.join(dir)) {
            found.extend(
                long_functions(&text, 80)
                    .into_iter()
                    .map(|f| format!("{dir}/{rel}: {f}")),
            );
        }
    }
    assert!(found.is_empty(), "over 80 lines:\n{}", found.join("\n"));
}

#[test]
fn the_length_check_counts_a_function_to_its_closing_brace() {
    let body = "    let x = 1;\n".repeat(3);
    let text = format!(
        "fn short() {{\n{body}}}\n\nimpl A {{\n    pub fn long(&self) {{\n{}    }}\n}}\n",
        body.repeat(30)
    );
    assert_eq!(
        long_functions(&text, 80),
        vec!["long (92 lines)".to_string()]
    );
    assert!(long_functions(&text, 92).is_empty());
}
