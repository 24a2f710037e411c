//! The code's structure, as docs/ARCHITECTURE.md states it: no import cycle between files of any
//! crate, no import from a lower layer of the host to a higher one, and no source file (tests,
//! benchmarks and firmware binaries included) over 800 lines unless docs/ARCHITECTURE.md says why
//! it is one piece.
//!
//! Imports are read from the source text: every `crate::…`, `super::…`, `self::…` path (in `use`
//! trees and inline) and, in the `sinew` binary, every `sinew_host::…` path, resolved to the file
//! of the deepest module it names. A module's own submodules are its contents, not its imports
//! (`mod.rs` re-exporting a child is a facade), so only edges to siblings, ancestors and their
//! other descendants count. Comments are skipped, so doc links are not imports, and so is test
//! code (`#[cfg(test)]` modules and `tests.rs` files): a test may use fixtures from anywhere.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The host's layers, lowest first: a file may import from its own top-level module or from a
/// lower layer only. Modules of one layer are independent of each other.
const HOST_LAYERS: &[&[&str]] = &[
    &["io"],
    &["geometry"],
    &["figures"],
    &["anatomy", "training", "rig"],
    &["aim", "s2d", "fit", "motion", "driver", "performance"],
    &["replay", "export"],
    &["view"],
    &["cli"],
];

/// Longest source file, in lines, that needs no reason in docs/ARCHITECTURE.md.
const MAX_LINES: usize = 800;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// One crate's source tree: module path (`["aim", "train"]`) → file.
struct Tree {
    name: String,
    modules: BTreeMap<Vec<String>, PathBuf>,
}

fn rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rs_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

fn tree(name: &str, src: &Path) -> Tree {
    let mut files = Vec::new();
    rs_files(src, &mut files);
    let modules = files
        .into_iter()
        .filter(|f| !f.ends_with("tests.rs"))
        .filter(|f| !f.ends_with("main.rs") || f.parent() == Some(src))
        .map(|f| (module_path(src, &f), f))
        .collect();
    Tree {
        name: name.to_owned(),
        modules,
    }
}

/// The source without comments (line comments and doc comments; block comments are not used).
fn code_lines(text: &str) -> Vec<String> {
    text.lines()
        .map(|l| match l.find("//") {
            // A `//` inside a string literal ("http://") is rare in this code base; cutting the
            // line there can only hide a path, never invent one.
            Some(i) => l[..i].to_owned(),
            None => l.to_owned(),
        })
        .collect()
}

/// Expands a `use` tree (`a::{b, c::{d, e}}`) into its paths.
fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        return vec![tree.to_owned()];
    };
    let prefix = &tree[..open];
    let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, ch) in inner.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .filter(|p| !p.trim().is_empty())
        .flat_map(expand)
        .map(|p| format!("{prefix}{p}"))
        .collect()
}

/// Every module path a file refers to, as segments from the crate root, with the line it is on.
fn references(
    tree: &Tree,
    module: &[String],
    text: &str,
    binary_of: Option<&str>,
) -> Vec<Vec<String>> {
    let lines = code_lines(text);
    // Inline modules (`mod tests {`) by indentation: `super` inside them first leaves them.
    let mut inline: Vec<usize> = Vec::new();
    let mut paths: Vec<(usize, String)> = Vec::new();
    let mut pending_use: Option<(usize, String)> = None;
    // Inside a `#[cfg(test)]` inline module: the indentation of its `mod` line.
    let mut test_block: Option<usize> = None;
    let mut cfg_test = false;
    for line in &lines {
        let indent = line.len() - line.trim_start().len();
        let t = line.trim();
        if let Some(at) = test_block {
            if t == "}" && indent == at {
                test_block = None;
            }
            continue;
        }
        if t == "#[cfg(test)]" {
            cfg_test = true;
            continue;
        }
        if std::mem::take(&mut cfg_test) && t.contains("mod ") && t.ends_with('{') {
            test_block = Some(indent);
            continue;
        }
        if t == "}" && inline.last() == Some(&indent) {
            inline.pop();
            continue;
        }
        let depth = inline.len();
        if let Some((d, mut u)) = pending_use.take() {
            u.push_str(t);
            if t.ends_with(';') {
                paths.extend(expand(u.trim_end_matches(';')).into_iter().map(|p| (d, p)));
            } else {
                pending_use = Some((d, u));
            }
            continue;
        }
        let is_mod = (t.starts_with("mod ")
            || t.starts_with("pub mod ")
            || t.starts_with("pub(crate) mod "))
            && t.ends_with('{');
        if is_mod {
            inline.push(indent);
            continue;
        }
        if let Some(rest) = t
            .strip_prefix("pub use ")
            .or_else(|| t.strip_prefix("pub(crate) use "))
            .or_else(|| t.strip_prefix("use "))
        {
            if rest.ends_with(';') {
                paths.extend(
                    expand(rest.trim_end_matches(';'))
                        .into_iter()
                        .map(|p| (depth, p)),
                );
            } else {
                pending_use = Some((depth, rest.to_owned()));
            }
            continue;
        }
        // Inline paths.
        let bytes = t.as_bytes();
        for start in ["crate::", "super::", "self::", "sinew_host::"] {
            let mut from = 0;
            while let Some(i) = t[from..].find(start) {
                let at = from + i;
                let boundary = at == 0
                    || !(bytes[at - 1].is_ascii_alphanumeric()
                        || bytes[at - 1] == b'_'
                        || bytes[at - 1] == b':');
                let end = t[at..]
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'))
                    .map_or(t.len(), |e| at + e);
                if boundary {
                    paths.push((depth, t[at..end].to_owned()));
                }
                from = end.max(at + 1);
            }
        }
    }
    let mut out = Vec::new();
    for (depth, path) in paths {
        let segs: Vec<&str> = path
            .split("::")
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .collect();
        let Some((&head, rest)) = segs.split_first() else {
            continue;
        };
        let mut base: Vec<String> = match head {
            "crate" => Vec::new(),
            "sinew_host" if binary_of.is_some() => Vec::new(),
            "self" => module.to_vec(),
            "super" => {
                let mut b = module.to_vec();
                let mut ups: usize = 1;
                let mut r = rest;
                while let Some((&"super", more)) = r.split_first() {
                    ups += 1;
                    r = more;
                }
                // The first `depth` supers leave inline modules of this file.
                for _ in 0..ups.saturating_sub(depth) {
                    b.pop();
                }
                let resolved = resolve(tree, b, r);
                out.push(resolved);
                continue;
            }
            _ => continue,
        };
        base = resolve(tree, std::mem::take(&mut base), rest);
        out.push(base);
    }
    out
}

/// The deepest module of `tree` that `base` + a prefix of `rest` names.
fn resolve(tree: &Tree, mut base: Vec<String>, rest: &[&str]) -> Vec<String> {
    for seg in rest {
        let mut next = base.clone();
        next.push((*seg).to_owned());
        if tree.modules.contains_key(&next) {
            base = next;
        } else {
            break;
        }
    }
    base
}

/// The file-level import graph of a crate: file module → modules it imports (its own
/// descendants excluded).
fn graph(tree: &Tree) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    tree.modules
        .iter()
        .map(|(module, file)| {
            let text = std::fs::read_to_string(file).unwrap();
            let edges = references(tree, module, &text, None)
                .into_iter()
                .filter(|r| !r.starts_with(module))
                .collect();
            (module.clone(), edges)
        })
        .collect()
}

fn display(tree: &Tree, m: &[String]) -> String {
    tree.modules
        .get(m)
        .map(|p| p.strip_prefix(repo()).unwrap_or(p).display().to_string())
        .unwrap_or_else(|| format!("{}::{}", tree.name, m.join("::")))
}

/// The first cycle of `g`, if any, as a list of modules.
fn cycle(g: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Option<Vec<Vec<String>>> {
    fn visit(
        g: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        n: &Vec<String>,
        state: &mut BTreeMap<Vec<String>, u8>,
        stack: &mut Vec<Vec<String>>,
    ) -> Option<Vec<Vec<String>>> {
        state.insert(n.clone(), 1);
        stack.push(n.clone());
        for m in g.get(n).into_iter().flatten() {
            if !g.contains_key(m) {
                continue;
            }
            match state.get(m).copied().unwrap_or(0) {
                1 => {
                    let i = stack.iter().position(|s| s == m).unwrap();
                    let mut c = stack[i..].to_vec();
                    c.push(m.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(g, m, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in g.keys() {
        if state.get(n).copied().unwrap_or(0) == 0
            && let Some(c) = visit(g, n, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

/// Every crate whose files are checked: (name, src folder).
fn crates() -> Vec<(String, PathBuf)> {
    let root = repo();
    let mut out = vec![
        ("sinew-core".to_owned(), root.join("core/src")),
        ("sinew-host".to_owned(), root.join("host/src")),
        ("sinew-tests".to_owned(), root.join("tests/src")),
        (
            "firmware-common".to_owned(),
            root.join("firmware-sim/common/src"),
        ),
    ];
    for sub in ["ffi", "wasm"] {
        let src = root.join("core").join(sub).join("src");
        if src.is_dir() {
            out.push((format!("sinew-{sub}"), src));
        }
    }
    out
}

#[test]
fn no_import_cycle_between_files() {
    let mut failures = Vec::new();
    for (name, src) in crates() {
        let mut t = tree(&name, &src);
        // The host's binary (`main.rs`, `cli/`) is a crate of its own over the library.
        if name == "sinew-host" {
            t.modules
                .retain(|m, _| m.first().map(String::as_str) != Some("cli"));
            t.modules.remove(&Vec::new());
        }
        let g = graph(&t);
        if let Some(c) = cycle(&g) {
            failures.push(format!(
                "{name}: import cycle {}",
                c.iter()
                    .map(|m| display(&t, m))
                    .collect::<Vec<_>>()
                    .join(" -> ")
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every import of a file under `src` from a module that is not in a lower layer of `layers`.
fn layer_violations(src: &Path, layers: &[&[&str]]) -> Vec<String> {
    let lib = tree("sinew-host", src);
    let rank = |top: &str| layers.iter().position(|l| l.contains(&top));
    let mut failures = Vec::new();
    for (module, file) in &lib.modules {
        let Some(top) = module.first() else { continue };
        let Some(from) = rank(top) else {
            failures.push(format!(
                "{}: top-level module `{top}` has no layer in HOST_LAYERS (and docs/ARCHITECTURE.md)",
                display(&lib, module)
            ));
            continue;
        };
        let text = std::fs::read_to_string(file).unwrap();
        let binary = (top == "cli").then_some("sinew_host");
        for r in references(&lib, module, &text, binary) {
            let Some(to_top) = r.first() else { continue };
            if to_top == top {
                continue;
            }
            if rank(to_top).is_none_or(|to| to >= from) {
                failures.push(format!(
                    "{} imports {} (`{}`), which is not in a lower layer",
                    display(&lib, module),
                    display(&lib, &r),
                    r.join("::")
                ));
            }
        }
    }
    failures.sort();
    failures.dedup();
    failures
}

#[test]
fn host_layers_import_only_downwards() {
    let failures = layer_violations(&repo().join("host/src"), HOST_LAYERS);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn long_files_are_explained() {
    let architecture = std::fs::read_to_string(repo().join("docs/ARCHITECTURE.md")).unwrap();
    let explained = architecture
        .split("### Files kept whole")
        .nth(1)
        .map(|s| s.split("\n## ").next().unwrap_or(s))
        .expect("docs/ARCHITECTURE.md has a \"### Files kept whole\" section");
    let mut failures = Vec::new();
    // Every crate's sources, and the tests, benchmarks and firmware binaries beside them.
    let others = [
        "host/tests",
        "host/benches",
        "tests/tests",
        "core/ffi/tests",
        "core/wasm/tests",
        "core/fuzz/fuzz_targets",
        "firmware-sim/cortex-m/src",
        "firmware-sim/riscv/src",
        "firmware-sim/wasm/src",
    ]
    .map(|d| repo().join(d));
    let folders = crates()
        .into_iter()
        .map(|(_, src)| src)
        .chain(others.into_iter().filter(|d| d.is_dir()));
    for src in folders {
        let mut files = Vec::new();
        rs_files(&src, &mut files);
        for f in files {
            let lines = std::fs::read_to_string(&f).unwrap().lines().count();
            let rel = f.strip_prefix(repo()).unwrap().display().to_string();
            if lines > MAX_LINES && !explained.contains(&format!("`{rel}`")) {
                failures.push(format!(
                    "{rel}: {lines} lines (over {MAX_LINES}) and not explained under \"Files kept whole\" in docs/ARCHITECTURE.md"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The integration tests of `dir` that break the one-binary rule (docs/ARCHITECTURE.md, "One test
/// binary per crate"): a `.rs` file directly in `dir` (its own binary), or a file of `dir/suite`
/// that `suite/main.rs` leaves out (never compiled).
fn test_binary_violations(dir: &Path) -> Vec<String> {
    let rel = |p: &Path| p.strip_prefix(repo()).unwrap_or(p).display().to_string();
    let mut failures = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return failures;
    };
    for entry in entries {
        let p = entry.unwrap().path();
        if p.is_file() && p.extension().is_some_and(|e| e == "rs") {
            failures.push(format!(
                "{}: a test binary of its own; make it a module of suite/main.rs",
                rel(&p)
            ));
        }
    }
    let suite = dir.join("suite");
    let main = std::fs::read_to_string(suite.join("main.rs")).unwrap_or_default();
    let declared: BTreeSet<String> = code_lines(&main)
        .iter()
        .filter_map(|l| {
            l.trim()
                .strip_prefix("mod ")?
                .strip_suffix(';')
                .map(str::to_owned)
        })
        .collect();
    let Ok(entries) = std::fs::read_dir(&suite) else {
        failures.push(format!("{}: no suite/main.rs", rel(dir)));
        return failures;
    };
    for entry in entries {
        let p = entry.unwrap().path();
        let name = p.file_stem().unwrap().to_string_lossy().into_owned();
        let module = p.is_dir() || p.extension().is_some_and(|e| e == "rs");
        if module && name != "main" && !declared.contains(&name) {
            failures.push(format!(
                "{}: not a module of suite/main.rs, so never compiled",
                rel(&p)
            ));
        }
    }
    failures
}

#[test]
fn integration_tests_are_one_binary_per_crate() {
    let failures: Vec<String> = ["host/tests", "tests/tests"]
        .iter()
        .flat_map(|d| test_binary_violations(&repo().join(d)))
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_test_binary_check_finds_a_stray_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("suite")).unwrap();
    std::fs::write(
        dir.path().join("suite/main.rs"),
        "mod kept;\n// mod commented;\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("suite/kept.rs"), "").unwrap();
    std::fs::write(dir.path().join("suite/commented.rs"), "").unwrap();
    std::fs::write(dir.path().join("alone.rs"), "").unwrap();
    let mut found = test_binary_violations(dir.path());
    found.sort();
    assert_eq!(found.len(), 2, "{found:?}");
    assert!(
        found[0].contains("alone.rs") && found[0].contains("of its own"),
        "{found:?}"
    );
    assert!(
        found[1].contains("commented.rs") && found[1].contains("never compiled"),
        "{found:?}"
    );
}

/// The files of the host's library that use `anyhow` outside their tests: only the edge may
/// (`main.rs`, `cli/`, the `*/commands.rs` glue); `src` is the host's source folder.
fn anyhow_outside_the_edge(src: &Path) -> Vec<String> {
    let mut files = Vec::new();
    rs_files(src, &mut files);
    let mut out = Vec::new();
    for f in files {
        let rel = f.strip_prefix(src).unwrap();
        let edge = rel.starts_with("cli")
            || rel
                .file_name()
                .is_some_and(|n| n == "main.rs" || n == "commands.rs")
            || rel.file_name().is_some_and(|n| n == "tests.rs")
            || rel.components().any(|c| c.as_os_str() == "tests");
        if edge {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        let library = text.split("#[cfg(test)]").next().unwrap_or_default();
        if let Some((n, _)) = library
            .lines()
            .enumerate()
            .find(|(_, l)| l.contains("anyhow") && !l.trim_start().starts_with("//"))
        {
            out.push(format!(
                "{}:{}: anyhow in a library module (return a thiserror enum; anyhow belongs to main.rs, cli/ and */commands.rs)",
                rel.display(),
                n + 1
            ));
        }
    }
    out
}

#[test]
fn host_library_errors_are_typed() {
    let failures = anyhow_outside_the_edge(&repo().join("host/src"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_anyhow_check_finds_a_library_use() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("aim")).unwrap();
    std::fs::create_dir_all(src.join("cli")).unwrap();
    std::fs::write(src.join("aim/train.rs"), "use anyhow::Result;\n").unwrap();
    std::fs::write(src.join("aim/commands.rs"), "use anyhow::Result;\n").unwrap();
    std::fs::write(src.join("cli/aim.rs"), "use anyhow::Result;\n").unwrap();
    std::fs::write(
        src.join("aim/bake.rs"),
        "pub fn f() {}\n#[cfg(test)]\nmod tests { fn g() -> anyhow::Result<()> { Ok(()) } }\n",
    )
    .unwrap();
    let found = anyhow_outside_the_edge(src);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].starts_with("aim/train.rs:1:"), "{found:?}");
}

/// The checker itself: a cycle and an upward import in a made-up tree are found.
#[test]
fn the_checks_find_what_they_look_for() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("io")).unwrap();
    std::fs::write(src.join("lib.rs"), "pub mod io;\npub mod aim;\n").unwrap();
    std::fs::write(src.join("io/mod.rs"), "pub mod mesh;\npub mod ict;\n").unwrap();
    std::fs::write(
        src.join("io/mesh.rs"),
        "use super::ict::Kit; // ict's type\nfn f() { crate::aim::go(); }\n",
    )
    .unwrap();
    std::fs::write(
        src.join("io/ict.rs"),
        "/// [`crate::aim`] in a comment is no import.\nuse crate::io::{mesh::{Mesh, read}};\n#[cfg(test)]\nmod tests {\n    use crate::aim::go;\n}\n",
    )
    .unwrap();
    std::fs::write(src.join("aim.rs"), "pub fn go() {}\n").unwrap();
    let t = tree("demo", src);
    let g = graph(&t);
    let c = cycle(&g).expect("mesh -> ict -> mesh is a cycle");
    assert_eq!(c.len(), 3);
    let mesh = vec!["io".to_owned(), "mesh".to_owned()];
    let ict = vec!["io".to_owned(), "ict".to_owned()];
    assert!(g[&mesh].contains(&ict) && g[&ict].contains(&mesh));
    assert!(g[&mesh].contains(&vec!["aim".to_owned()]));
    assert!(
        !g[&ict].contains(&vec!["aim".to_owned()]),
        "comments are not imports"
    );
}

/// Every source file the docs name by path (`host/src/io/mesh.rs`, `scripts/check.sh`, …)
/// exists, so the docs follow the code when it moves.
#[test]
fn docs_name_files_that_exist() {
    let root = repo();
    let mut docs = vec![root.join("README.md"), root.join("firmware-sim/README.md")];
    for dir in ["docs", "docs/results"] {
        let mut files: Vec<PathBuf> = std::fs::read_dir(root.join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "md"))
            .collect();
        files.sort();
        docs.extend(files);
    }
    const EXTENSIONS: &[&str] = &["rs", "py", "sh", "mjs", "c", "h", "toml"];
    let mut missing = Vec::new();
    for doc in docs {
        let text = std::fs::read_to_string(&doc).unwrap();
        for start in ["host/", "core/", "tests/", "firmware-sim/", "scripts/"] {
            let mut from = 0;
            while let Some(i) = text[from..].find(start) {
                let at = from + i;
                let end = text[at..]
                    .find(|c: char| !(c.is_ascii_alphanumeric() || "_./-".contains(c)))
                    .map_or(text.len(), |e| at + e);
                from = end.max(at + 1);
                let before = text[..at].chars().next_back();
                if before.is_some_and(|c| c.is_ascii_alphanumeric() || "_./-".contains(c)) {
                    continue;
                }
                let path = text[at..end].trim_end_matches('.');
                let is_source = path
                    .rsplit_once('.')
                    .is_some_and(|(_, ext)| EXTENSIONS.contains(&ext));
                if is_source && !root.join(path).exists() {
                    missing.push(format!(
                        "{}: names {path}, which does not exist",
                        doc.strip_prefix(&root).unwrap().display()
                    ));
                }
            }
        }
    }
    missing.sort();
    missing.dedup();
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}
