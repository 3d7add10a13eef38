//! The architecture's invariants as a test, after rust-analyzer's `tidy`: ARCHITECTURE.md states
//! them, this file checks each over the source tree, so a change that breaks one fails here.
//!
//! - every CLI file is under 300 lines;
//! - no library prints (`print!`, `println!`, `eprint!`, `eprintln!`, `dbg!` outside tests);
//! - every crate opens with a crate doc and every module with a doc comment of two lines or more;
//! - no import circles between the modules of any crate (and no crate imports a crate above it);
//! - every declared dependency is used;
//! - every library crate that reads files has property tests (`tests/robust_*.rs`, `proptest!`).
//!
//! The module graph: a node per source file, the crate root included; an arrow from a file to
//! every module a path in its non-test code resolves to (`crate::`, `super::`, `self::` or a
//! child's name), following `pub use` re-exports to the module that defines the item. A file's
//! facade (`mod` declarations, `pub use`) is containment, not an import.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// Every `.rs` file below `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(rust_files(&p));
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
    out.sort();
    out
}

fn crates() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(workspace().join("crates"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join("Cargo.toml").exists())
        .collect();
    v.sort();
    v
}

fn name_of(krate: &Path) -> String {
    krate.file_name().unwrap().to_string_lossy().into_owned()
}

/// `src` with comments, string and char literals blanked (newlines kept, so lines still count).
fn strip_comments_and_strings(src: &str) -> String {
    scan(src).0
}

/// [`strip_comments_and_strings`] and the byte ranges of the string literals (same offsets in
/// both: every byte is blanked to one byte).
fn scan(src: &str) -> (String, Vec<std::ops::Range<usize>>) {
    let b = src.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut strings = Vec::new();
    let mut i = 0;
    let blank = |out: &mut Vec<u8>, c: u8| out.push(if c == b'\n' { b'\n' } else { b' ' });
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                out.push(b' ');
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                    depth += 1;
                    out.extend_from_slice(b"  ");
                    i += 2;
                } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                    depth -= 1;
                    out.extend_from_slice(b"  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, b[i]);
                    i += 1;
                }
            }
        } else if b[i] == b'r'
            && (b.get(i + 1) == Some(&b'"') || b.get(i + 1) == Some(&b'#'))
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_'))
        {
            // Raw string r"…" or r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&b'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&b'"') {
                out.push(b[i]);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                if j >= b.len() {
                    break;
                }
                if b[j] == b'"' && (0..hashes).all(|k| b.get(j + 1 + k) == Some(&b'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            for &c in &b[i..j.min(b.len())] {
                blank(&mut out, c);
            }
            strings.push(i..j.min(b.len()));
            i = j;
        } else if b[i] == b'"' {
            let start = i;
            out.push(b' ');
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    out.push(b' ');
                    i += 1;
                }
                if i < b.len() {
                    blank(&mut out, b[i]);
                    i += 1;
                }
            }
            out.push(b' ');
            i += 1;
            strings.push(start..i.min(b.len()));
        } else if b[i] == b'\'' {
            // A char literal ('x', '\n', '\u{..}') or a lifetime ('a): blank only the former.
            let end = if b.get(i + 1) == Some(&b'\\') {
                b[i + 2..]
                    .iter()
                    .position(|&c| c == b'\'')
                    .map(|p| i + 2 + p)
            } else if b.get(i + 2) == Some(&b'\'') {
                Some(i + 2)
            } else {
                // Multi-byte UTF-8 char literal.
                let s = &src[i + 1..];
                s.chars().next().and_then(|c| {
                    let l = c.len_utf8();
                    (b.get(i + 1 + l) == Some(&b'\'')).then_some(i + 1 + l)
                })
            };
            match end {
                Some(e) => {
                    out.extend(std::iter::repeat_n(b' ', e + 1 - i));
                    i = e + 1;
                }
                None => {
                    out.push(b[i]);
                    i += 1;
                }
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    (String::from_utf8_lossy(&out).into_owned(), strings)
}

/// The index just past the item that starts at `from` (a `{…}` block or up to a `;` outside any
/// bracket: `fn f() -> [f32; 3] {…}` ends at its brace).
fn item_end(code: &[u8], from: usize) -> usize {
    let (mut braces, mut other) = (0i32, 0i32);
    let mut i = from;
    while i < code.len() {
        match code[i] {
            b'{' => braces += 1,
            b'}' => {
                braces -= 1;
                if braces == 0 && other == 0 {
                    return i + 1;
                }
            }
            b'(' | b'[' => other += 1,
            b')' | b']' => other -= 1,
            b';' if braces == 0 && other == 0 => return i + 1,
            _ => {}
        }
        i += 1;
    }
    code.len()
}

/// The byte ranges of the items under `#[cfg(test)]` in comment- and string-free `code`.
fn test_items(code: &str) -> Vec<std::ops::Range<usize>> {
    let mut items = Vec::new();
    let mut at = 0;
    while let Some(p) = code[at..].find("#[cfg(test)]") {
        let start = at + p;
        let end = item_end(code.as_bytes(), start + "#[cfg(test)]".len());
        items.push(start..end);
        at = end;
    }
    items
}

/// Comment-free code without the items under `#[cfg(test)]` (test modules and helpers).
fn non_test_code(src: &str) -> String {
    let code = strip_comments_and_strings(src);
    let mut out = code.clone().into_bytes();
    for r in test_items(&code) {
        for c in &mut out[r] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
    }
    String::from_utf8(out).unwrap()
}

/// One crate's modules: path segments (`["numerics", "lanes"]`) → file.
struct Crate {
    modules: BTreeMap<Vec<String>, PathBuf>,
    /// Facade re-exports: module → (name → the module path it names).
    reexports: BTreeMap<Vec<String>, BTreeMap<String, Vec<String>>>,
}

fn module_path(src_dir: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src_dir).unwrap();
    let mut segs: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if segs
        .last()
        .is_some_and(|s| s == "mod" || s == "lib" || s == "main")
    {
        segs.pop();
    }
    segs
}

/// Paths that start with `crate`, `super` or `self` in `code`, with `{a, b::c}` groups expanded.
fn paths_in(code: &str) -> Vec<Vec<String>> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    for kw in ["crate", "super", "self"] {
        let mut at = 0;
        while let Some(p) = code[at..].find(kw) {
            let s = at + p;
            at = s + kw.len();
            let before_ok = s == 0
                || !(b[s - 1].is_ascii_alphanumeric() || b[s - 1] == b'_' || b[s - 1] == b':');
            if !before_ok || !code[at..].trim_start().starts_with("::") {
                continue;
            }
            let mut acc = Vec::new();
            expand(code, s, &[], &mut acc);
            out.extend(acc);
        }
    }
    out
}

/// Expands the path starting at `i` (after `prefix`) into `out`.
fn expand(code: &str, mut i: usize, prefix: &[String], out: &mut Vec<Vec<String>>) -> usize {
    let b = code.as_bytes();
    let mut segs = prefix.to_vec();
    loop {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        if i < b.len() && b[i] == b'{' {
            i += 1;
            loop {
                while i < b.len() && (b[i].is_ascii_whitespace() || b[i] == b',') {
                    i += 1;
                }
                if i >= b.len() || b[i] == b'}' {
                    out.push(segs.clone());
                    return i + 1;
                }
                i = expand(code, i, &segs, out);
            }
        }
        let st = i;
        while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
            i += 1;
        }
        if i == st {
            out.push(segs);
            return i;
        }
        segs.push(code[st..i].to_string());
        let mut j = i;
        while j < b.len() && b[j].is_ascii_whitespace() {
            j += 1;
        }
        if code[j..].starts_with("::") {
            i = j + 2;
        } else {
            out.push(segs);
            return i;
        }
    }
}

impl Crate {
    fn load(krate: &Path) -> Crate {
        let src = krate.join("src");
        let mut modules = BTreeMap::new();
        for f in rust_files(&src) {
            if f.parent().unwrap().ends_with("bin") {
                continue;
            }
            modules.insert(module_path(&src, &f), f);
        }
        let mut c = Crate {
            modules,
            reexports: BTreeMap::new(),
        };
        // Facade re-exports, from `pub use` lines of every module.
        let files: Vec<(Vec<String>, PathBuf)> = c
            .modules
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        for (m, f) in files {
            let code = non_test_code(&std::fs::read_to_string(&f).unwrap());
            let mut map = BTreeMap::new();
            for stmt in code.split(';') {
                let t = stmt.trim();
                let Some(rest) = t
                    .strip_prefix("pub use ")
                    .or_else(|| t.strip_prefix("pub(crate) use "))
                else {
                    continue;
                };
                let rest = rest.trim();
                let mut acc = Vec::new();
                expand(rest, 0, &[], &mut acc);
                for p in acc {
                    let Some(last) = p.last().cloned() else {
                        continue;
                    };
                    let target = c.absolute(&m, &p);
                    if let Some(t) = target {
                        map.insert(last, t);
                    }
                }
            }
            c.reexports.insert(m, map);
        }
        c
    }

    /// The absolute segments of `path` written in module `from` (`crate::`, `super::`, `self::`
    /// or a child module's name), or None for another crate's path.
    fn absolute(&self, from: &[String], path: &[String]) -> Option<Vec<String>> {
        let first = path.first()?;
        let (mut base, rest): (Vec<String>, &[String]) = match first.as_str() {
            "crate" => (Vec::new(), &path[1..]),
            "self" => (from.to_vec(), &path[1..]),
            "super" => {
                let mut b = from.to_vec();
                let mut k = 0;
                while path.get(k).is_some_and(|s| s == "super") {
                    b.pop();
                    k += 1;
                }
                (b, &path[k..])
            }
            _ => {
                let mut child = from.to_vec();
                child.push(first.clone());
                if self.modules.contains_key(&child) {
                    (from.to_vec(), path)
                } else {
                    return None;
                }
            }
        };
        base.extend(rest.iter().cloned());
        Some(base)
    }

    /// The module that defines what absolute `path` names.
    fn resolve(&self, path: &[String], depth: usize) -> Vec<String> {
        let mut m: Vec<String> = Vec::new();
        for seg in path {
            let mut child = m.clone();
            child.push(seg.clone());
            if self.modules.contains_key(&child) {
                m = child;
                continue;
            }
            if depth < 8 {
                if let Some(t) = self.reexports.get(&m).and_then(|r| r.get(seg)) {
                    if t != path {
                        return self.resolve(t, depth + 1);
                    }
                }
            }
            break;
        }
        m
    }

    /// Arrows between modules (test code left out). A module's facade — its `mod` declarations
    /// and `pub use` re-exports — is containment, not an import; every other path in its code
    /// is an arrow, to a sibling, a parent or a child alike (the crate root is a module too).
    fn graph(&self) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
        let mut g: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
        for (m, f) in &self.modules {
            let code = without_facade(&non_test_code(&std::fs::read_to_string(f).unwrap()));
            let children: Vec<String> = self
                .modules
                .keys()
                .filter(|k| k.len() == m.len() + 1 && k.starts_with(m))
                .map(|k| k[m.len()].clone())
                .collect();
            let set = g.entry(m.clone()).or_default();
            for p in paths_in(&code)
                .into_iter()
                .chain(child_paths(&code, &children))
            {
                let Some(abs) = self.absolute(m, &p) else {
                    continue;
                };
                let t = self.resolve(&abs, 0);
                if &t != m {
                    set.insert(t);
                }
            }
        }
        g
    }
}

/// `code` with its facade blanked: `mod x;`, `pub mod x;` and `pub use …;` / `pub(crate) use …;`
/// statements.
fn without_facade(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut skipping = false;
    for line in code.lines() {
        let t = line.trim_start();
        if !skipping
            && [
                "pub use ",
                "pub(crate) use ",
                "mod ",
                "pub mod ",
                "pub(crate) mod ",
            ]
            .iter()
            .any(|p| t.starts_with(p))
            && !t.contains('{')
            || !skipping && (t.starts_with("pub use ") || t.starts_with("pub(crate) use "))
        {
            skipping = !t.contains(';');
            out.push('\n');
            continue;
        }
        if skipping {
            skipping = !t.contains(';');
            out.push('\n');
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Paths in `code` that start with one of `children` (a module's own child modules, named
/// without `self::`), with groups expanded.
fn child_paths(code: &str, children: &[String]) -> Vec<Vec<String>> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    for c in children {
        let pat = format!("{c}::");
        for (i, _) in code.match_indices(&pat) {
            if i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b':') {
                continue;
            }
            expand(code, i, &[], &mut out);
        }
    }
    out
}

/// Strongly connected components of more than one module (Tarjan).
fn circles(g: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Vec<Vec<Vec<String>>> {
    struct T<'a> {
        g: &'a BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        index: BTreeMap<&'a Vec<String>, usize>,
        low: BTreeMap<&'a Vec<String>, usize>,
        stack: Vec<&'a Vec<String>>,
        on: BTreeSet<&'a Vec<String>>,
        next: usize,
        out: Vec<Vec<Vec<String>>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a Vec<String>) {
        t.index.insert(v, t.next);
        t.low.insert(v, t.next);
        t.next += 1;
        t.stack.push(v);
        t.on.insert(v);
        if let Some(ws) = t.g.get(v) {
            for w in ws {
                let Some((w, _)) = t.g.get_key_value(w) else {
                    continue;
                };
                if !t.index.contains_key(w) {
                    visit(t, w);
                    let l = t.low[w].min(t.low[v]);
                    t.low.insert(v, l);
                } else if t.on.contains(w) {
                    let l = t.index[w].min(t.low[v]);
                    t.low.insert(v, l);
                }
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            loop {
                let w = t.stack.pop().unwrap();
                t.on.remove(w);
                comp.push(w.clone());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                t.out.push(comp);
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v) {
            visit(&mut t, v);
        }
    }
    t.out
}

/// Every import circle in the workspace, as `crate: a → b → a` lines.
fn all_circles() -> Vec<String> {
    let mut out = Vec::new();
    for k in crates() {
        let c = Crate::load(&k);
        for comp in circles(&c.graph()) {
            let names: Vec<String> = comp.iter().map(|m| m.join("/")).collect();
            out.push(format!("{}: {{{}}}", name_of(&k), names.join(", ")));
        }
    }
    out
}

#[test]
fn no_import_circles_inside_any_crate() {
    let found = all_circles();
    assert_none(&found, "import circles (modules that import each other):");
}

#[test]
fn the_circle_finder_finds_circles() {
    // The checker itself: a two-module circle through a facade's re-export, a `super::` path and
    // a grouped `use`, and the same modules without the back arrow.
    let dir = std::env::temp_dir().join(format!("derma-tidy-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("src/numerics")).unwrap();
    let put = |path: &str, text: &str| std::fs::write(dir.join(path), text).unwrap();
    put("Cargo.toml", "[package]\nname = \"x\"\n");
    put(
        "src/lib.rs",
        "//! x\npub mod rng;\npub mod numerics;\npub use rng::Philox;\n",
    );
    put(
        "src/numerics/mod.rs",
        "//! n\npub mod lanes;\npub use lanes::Lanes;\n",
    );
    put(
        "src/numerics/lanes.rs",
        "//! l\nuse crate::{Philox, map::X};\npub struct Lanes;\n",
    );
    put("src/rng.rs", "//! r\npub struct Philox;\nfn f() { let _ = crate::numerics::Lanes; }\n#[cfg(test)]\nmod tests { use super::*; }\n");
    let c = Crate::load(&dir);
    let found = circles(&c.graph());
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(
        found[0],
        vec![
            vec!["numerics".to_string(), "lanes".to_string()],
            vec!["rng".to_string()]
        ]
    );
    put("src/rng.rs", "//! r\npub struct Philox;\n");
    assert!(circles(&Crate::load(&dir).graph()).is_empty());
    // A root that defines an item a child uses, and calls into that child from its own code.
    put(
        "src/lib.rs",
        "//! x\npub mod rng;\npub mod numerics;\npub struct Seed;\nfn f() { rng::draw(); }\n",
    );
    put(
        "src/rng.rs",
        "//! r\npub fn draw() { let _ = crate::Seed; }\n",
    );
    let found = circles(&Crate::load(&dir).graph());
    assert_eq!(
        found,
        vec![vec![Vec::<String>::new(), vec!["rng".to_string()]]]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Fails with `what` and every finding, one a line, unless there are none.
fn assert_none(found: &[String], what: &str) {
    assert!(found.is_empty(), "{what}\n{}", found.join("\n"));
}

/// Library crates: every crate but the CLI.
fn libraries() -> Vec<PathBuf> {
    crates()
        .into_iter()
        .filter(|k| name_of(k) != "derma")
        .collect()
}

#[test]
fn cli_files_are_under_300_lines() {
    let mut long = Vec::new();
    for f in rust_files(&workspace().join("crates/derma/src")) {
        let n = std::fs::read_to_string(&f).unwrap().lines().count();
        if n >= 300 {
            long.push(format!("{} has {n} lines", f.display()));
        }
    }
    assert_none(
        &long,
        "CLI files must stay under 300 lines (parse → call → print):",
    );
}

/// The printing macros a library must not call outside its tests.
fn prints(code: &str) -> Vec<usize> {
    let mut at = Vec::new();
    for (i, line) in code.lines().enumerate() {
        for mac in ["println!", "print!", "eprintln!", "eprint!", "dbg!"] {
            if let Some(p) = line.find(mac) {
                let b = line.as_bytes();
                if p == 0 || !(b[p - 1].is_ascii_alphanumeric() || b[p - 1] == b'_') {
                    at.push(i + 1);
                    break;
                }
            }
        }
    }
    at
}

#[test]
fn libraries_never_print() {
    let mut found = Vec::new();
    for k in libraries() {
        if name_of(&k) == "derma-test-support" {
            continue; // the tests' own helpers say why a test skipped
        }
        for f in rust_files(&k.join("src")) {
            let code = non_test_code(&std::fs::read_to_string(&f).unwrap());
            for line in prints(&code) {
                found.push(format!("{}:{line}", f.display()));
            }
        }
    }
    assert_none(
        &found,
        "libraries report through derma_core::progress, never print:",
    );
}

/// The CLI's flags named in the string literals of a library's non-test code (`--size`, not a
/// peer's own flags such as `sbatch --array`), as `line: literal`.
fn flags_named(src: &str) -> Vec<String> {
    let (code, strings) = scan(src);
    let tests = test_items(&code);
    let mut found = Vec::new();
    for r in strings {
        let lit = &src[r.clone()];
        if tests.iter().any(|t| t.contains(&r.start)) {
            continue;
        }
        let names_flag = lit.match_indices("--").any(|(i, _)| {
            let before = lit[..i].chars().last();
            let after = lit[i + 2..].chars().next();
            matches!(before, Some(' ' | '"' | '(' | '`'))
                && after.is_some_and(|c| c.is_ascii_lowercase())
                && !lit[..i].ends_with("sbatch ")
        });
        if names_flag {
            let line = src[..r.start].matches('\n').count() + 1;
            found.push(format!("{line}: {lit}"));
        }
    }
    found
}

#[test]
fn library_messages_leave_flags_to_the_cli() {
    let mut found = Vec::new();
    for k in libraries() {
        for f in rust_files(&k.join("src")) {
            for hit in flags_named(&std::fs::read_to_string(&f).unwrap()) {
                found.push(format!("{}:{hit}", f.display()));
            }
        }
    }
    assert_none(
        &found,
        "a library's errors and notes name the value or option, and the CLI names its flag:",
    );
    // The check finds a flag in a message, and not in a test or a peer's command line.
    let probe = "fn f() -> String { \"choose a smaller --size\".into() }\n\
                 fn g() -> &'static str { \"sbatch --array=1-4\" }\n\
                 #[cfg(test)]\nmod tests { fn t() { let _ = \"--size 8\"; } }\n";
    assert_eq!(flags_named(probe).len(), 1, "{:?}", flags_named(probe));
}

/// The leading `//!` lines of a file.
fn module_doc(src: &str) -> Vec<&str> {
    src.lines().take_while(|l| l.starts_with("//!")).collect()
}

#[test]
fn every_crate_and_module_says_what_it_models() {
    let mut missing = Vec::new();
    for k in crates() {
        for f in rust_files(&k.join("src")) {
            let src = std::fs::read_to_string(&f).unwrap();
            let doc = module_doc(&src);
            let text: String = doc
                .iter()
                .map(|l| l.trim_start_matches("//!").trim())
                .collect::<Vec<_>>()
                .join(" ");
            if doc.len() < 2 || text.split_whitespace().count() < 12 {
                missing.push(format!(
                    "{}: a module opens with at least two lines of `//!` on what it models",
                    f.display()
                ));
            }
            let is_root = f.ends_with("src/lib.rs") || f.ends_with("src/main.rs");
            if is_root && name_of(&k) != "derma-test-support" && !cites_a_source(&text) {
                missing.push(format!(
                    "{}: the crate doc names its sources (a paper with its year, a thesis, docs/…, the seeds or a PROVENANCE file)",
                    f.display()
                ));
            }
        }
    }
    assert_none(&missing, "modules and crates without the docs they need:");
}

/// Whether `text` names a source: a year (a paper, a standard), a thesis, a page of docs/, the
/// papers' folder or a data PROVENANCE file.
fn cites_a_source(text: &str) -> bool {
    ["docs/", "seeds", "thesis", "PROVENANCE"]
        .iter()
        .any(|s| text.contains(s))
        || text
            .split(|c: char| !c.is_ascii_digit())
            .any(|w| w.len() == 4 && (w.starts_with("19") || w.starts_with("20")))
}

/// The entries of one table (`[dependencies]`, `[dev-dependencies]`) of a manifest, trimmed.
fn table_lines<'a>(manifest: &'a str, table: &str) -> Vec<&'a str> {
    let mut out = Vec::new();
    let mut inside = false;
    for line in manifest.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            inside = t == format!("[{table}]");
        } else if inside && !t.is_empty() && !t.starts_with('#') {
            out.push(t);
        }
    }
    out
}

/// The dependency names of one table of a manifest.
fn dependencies(manifest: &str, table: &str) -> Vec<String> {
    table_lines(manifest, table)
        .iter()
        .filter_map(|t| t.split(['=', '.']).next())
        .map(|name| name.trim().to_string())
        .collect()
}

/// All the Rust text of `dirs` below `krate`.
fn text_of(krate: &Path, dirs: &[&str]) -> String {
    dirs.iter()
        .flat_map(|d| rust_files(&krate.join(d)))
        .map(|f| std::fs::read_to_string(f).unwrap())
        .collect::<Vec<_>>()
        .join("\n")
}

/// Whether `pat` occurs in `text` not preceded by an identifier character (`exr::` is not in
/// `use exr_writer`, nor `png::` in `apng::`).
fn has_word(text: &str, pat: &str) -> bool {
    text.match_indices(pat).any(|(i, _)| {
        i == 0 || {
            let c = text.as_bytes()[i - 1];
            !(c.is_ascii_alphanumeric() || c == b'_')
        }
    })
}

#[test]
fn every_declared_dependency_is_used() {
    let mut unused = Vec::new();
    for k in crates() {
        let manifest = std::fs::read_to_string(k.join("Cargo.toml")).unwrap();
        // Code only (a comment naming a crate is no use of it), test modules out of `src`.
        let src: String = rust_files(&k.join("src"))
            .iter()
            .map(|f| non_test_code(&std::fs::read_to_string(f).unwrap()))
            .collect();
        let all =
            strip_comments_and_strings(&text_of(&k, &["src", "tests", "benches", "examples"]));
        for (table, text) in [("dependencies", &src), ("dev-dependencies", &all)] {
            for dep in dependencies(&manifest, table) {
                let ident = dep.replace('-', "_");
                let used = [
                    format!("{ident}::"),
                    format!("use {ident};"),
                    format!("crate {ident}"),
                    format!("{ident}!"),
                ]
                .iter()
                .any(|p| has_word(text, p));
                if !used {
                    unused.push(format!("{}: [{table}] {dep}", name_of(&k)));
                }
            }
        }
    }
    assert_none(&unused, "declared but never used:");
}

#[test]
fn every_crate_that_reads_files_has_property_tests() {
    let mut missing = Vec::new();
    for k in libraries() {
        let code: String = rust_files(&k.join("src"))
            .iter()
            .map(|f| non_test_code(&std::fs::read_to_string(f).unwrap()))
            .collect();
        let reads = [
            "fs::read(",
            "fs::read_to_string(",
            "File::open(",
            "image_io::read",
            "read_json(",
        ]
        .iter()
        .any(|p| code.contains(p));
        if !reads {
            continue;
        }
        let has = rust_files(&k.join("tests")).iter().any(|f| {
            f.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("robust_")
                && std::fs::read_to_string(f).unwrap().contains("proptest!")
        });
        if !has {
            missing.push(name_of(&k));
        }
    }
    assert!(
        missing.is_empty(),
        "crates that read files without property tests of their parsers (tests/robust_*.rs with proptest!): {}",
        missing.join(", ")
    );
}

#[test]
fn the_gpu_is_a_feature_and_off_by_default() {
    let mut wrong = Vec::new();
    for k in crates() {
        let manifest = std::fs::read_to_string(k.join("Cargo.toml")).unwrap();
        let name = name_of(&k);
        let deps = table_lines(&manifest, "dependencies");
        if let Some(w) = deps.iter().find(|t| t.starts_with("wgpu")) {
            if !w.contains("optional = true") {
                wrong.push(format!("{name}: wgpu is not optional ({w})"));
            }
            let gpu = table_lines(&manifest, "features")
                .into_iter()
                .find(|t| t.starts_with("gpu ="));
            match gpu {
                Some(f)
                    if f.contains("\"dep:wgpu\"")
                        && (name == "derma-core" || f.contains("\"derma-core/gpu\"")) => {}
                _ => wrong.push(format!(
                    "{name}: no `gpu` feature with dep:wgpu and derma-core/gpu"
                )),
            }
        }
        for t in table_lines(&manifest, "features") {
            if t.starts_with("default") && t.contains("gpu") {
                wrong.push(format!(
                    "{name}: the default features include the GPU ({t})"
                ));
            }
        }
        for lib in ["faer", "nalgebra", "ndarray-linalg", "lapack"] {
            if deps
                .iter()
                .any(|t| t.split(['=', '.', ' ']).next() == Some(lib))
            {
                wrong.push(format!(
                    "{name}: declares {lib} (numerics is derma-core's own)"
                ));
            }
        }
    }
    let root = std::fs::read_to_string(workspace().join("Cargo.toml")).unwrap();
    if table_lines(&root, "workspace.dependencies")
        .iter()
        .any(|t| t.starts_with("faer"))
    {
        wrong.push("the workspace declares faer".into());
    }
    assert_none(&wrong, "the GPU stays a feature, off by default:");
}

#[test]
fn every_dependency_is_declared_once_in_the_workspace() {
    let mut local = Vec::new();
    for k in crates() {
        let manifest = std::fs::read_to_string(k.join("Cargo.toml")).unwrap();
        for table in ["dependencies", "dev-dependencies", "build-dependencies"] {
            for t in table_lines(&manifest, table) {
                if !t.contains("workspace = true") {
                    local.push(format!("{}: {t}", name_of(&k)));
                }
            }
        }
    }
    assert_none(
        &local,
        "declare versions once, in [workspace.dependencies]:",
    );
}

#[test]
fn core_returns_only_its_own_errors() {
    // derma-core's public functions fail with CoreError, GpuError or NumericsError (through
    // `crate::Result<T>` or `Result<T, E>` naming one), never another crate's error type.
    let own = ["CoreError", "GpuError", "NumericsError"];
    let mut foreign = Vec::new();
    for f in rust_files(&workspace().join("crates/derma-core/src")) {
        let code = non_test_code(&std::fs::read_to_string(&f).unwrap());
        // Signatures span lines: join each `pub fn` up to its body.
        for (i, _) in code.match_indices("pub fn ") {
            let sig: String = code[i..]
                .chars()
                .take_while(|&c| c != '{' && c != ';')
                .collect();
            // The return type: after the last arrow before any `where` clause (a parameter may
            // be a closure with an arrow of its own).
            let head = sig
                .split([' ', '\n'])
                .take_while(|w| *w != "where")
                .collect::<Vec<_>>()
                .join(" ");
            let Some((_, ret)) = head.rsplit_once("->") else {
                continue;
            };
            let ret = ret.split_whitespace().collect::<String>();
            // A one-argument Result must be the crate's own (`Result<T>` or `crate::Result<T>`).
            let foreign_alias = ret
                .match_indices("::Result<")
                .any(|(i, _)| !ret[..i].ends_with("crate"));
            if foreign_alias || ret.contains("io::Result") || ret.contains("fmt::Result") {
                foreign.push(format!(
                    "{}: {}",
                    f.display(),
                    sig.lines().next().unwrap_or("")
                ));
            } else if let Some(p) = ret.find("Result<") {
                let args = &ret[p + 7..];
                let depth_zero_comma = {
                    let mut d = 0i32;
                    args.char_indices().find(|&(_, c)| {
                        match c {
                            '<' | '(' | '[' => d += 1,
                            '>' | ')' | ']' => d -= 1,
                            _ => {}
                        }
                        c == ',' && d == 0
                    })
                };
                if let Some((k, _)) = depth_zero_comma {
                    let err = args[k + 1..].trim_end_matches('>');
                    let name = err.rsplit("::").next().unwrap_or(err);
                    if !own.contains(&name) {
                        foreign.push(format!(
                            "{}: {}",
                            f.display(),
                            sig.lines().next().unwrap_or("")
                        ));
                    }
                }
            }
        }
    }
    assert_none(&foreign, "derma-core functions returning other errors:");
}

#[test]
fn crates_sit_on_their_floors() {
    // ARCHITECTURE.md's table `| floor | crate | … |`: every crate depends only on lower floors.
    let arch = std::fs::read_to_string(workspace().join("ARCHITECTURE.md")).unwrap();
    let mut floor = BTreeMap::new();
    for line in arch.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() > 3 {
            if let (Ok(n), Some(name)) = (
                cells[1].parse::<u32>(),
                cells[2].strip_prefix('`').and_then(|c| c.strip_suffix('`')),
            ) {
                floor.insert(name.to_string(), n);
            }
        }
    }
    let mut wrong = Vec::new();
    for k in crates() {
        let name = name_of(&k);
        if name == "derma-test-support" {
            continue;
        }
        let Some(&mine) = floor.get(&name) else {
            wrong.push(format!(
                "{name} is missing from ARCHITECTURE.md's crate table"
            ));
            continue;
        };
        let manifest = std::fs::read_to_string(k.join("Cargo.toml")).unwrap();
        for dep in dependencies(&manifest, "dependencies")
            .iter()
            .filter(|d| d.starts_with("derma"))
        {
            match floor.get(dep) {
                Some(&f) if f < mine => {}
                Some(&f) => wrong.push(format!(
                    "{name} (floor {mine}) depends on {dep} (floor {f})"
                )),
                None => wrong.push(format!("{name} depends on {dep}, which is in no floor")),
            }
        }
    }
    assert!(floor.len() >= 11, "the crate table was not read: {floor:?}");
    assert_none(&wrong, "crates off their floors:");
}

/// One error vocabulary: no library defines its own free-text `Invalid(String)`; a value that
/// cannot be used is derma-core's `Invalid {what, expected, got}`, wrapped (ARCHITECTURE.md).
#[test]
fn libraries_wrap_the_one_invalid_value_error() {
    let mut found = Vec::new();
    for krate in libraries() {
        for f in rust_files(&krate.join("src")) {
            let code = non_test_code(&std::fs::read_to_string(&f).unwrap());
            let squeezed: String = code.split_whitespace().collect();
            if squeezed.contains("Invalid(String)") {
                found.push(f.display().to_string());
            }
        }
    }
    assert_none(&found, "an own Invalid(String) error variant");
}

/// Every function with a body in `src` (comments, strings and `#[cfg(test)]` items left out):
/// its name and its length in lines, from the `fn` line to the closing brace.
fn function_lengths(src: &str) -> Vec<(String, usize)> {
    let code = non_test_code(src);
    let b = code.as_bytes();
    let mut out = Vec::new();
    let mut at = 0;
    while let Some(p) = code[at..].find("fn ") {
        let start = at + p;
        at = start + 3;
        let word_start =
            start == 0 || !(b[start - 1].is_ascii_alphanumeric() || b[start - 1] == b'_');
        if !word_start {
            continue;
        }
        let name: String = code[start + 3..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if name.is_empty() {
            continue;
        }
        let end = item_end(b, start);
        if b[end - 1] != b'}' {
            continue; // a declaration without a body (a trait's)
        }
        let lines = code[start..end].matches('\n').count() + 1;
        out.push((name, lines));
    }
    out
}

/// The most lines a new function may have (issue 62): it reads at once.
const MAX_FUNCTION_LINES: usize = 120;

/// Functions longer than [`MAX_FUNCTION_LINES`] when the ratchet was set (issue 62), with their
/// lengths then: each may only shrink, and leaves the list once it is short.
const LONG_FUNCTIONS: &[(&str, &str, usize)] = &[
    ("crates/derma/src/photo.rs", "run", 211),
    ("crates/derma-export/src/glb.rs", "export", 312),
    ("crates/derma-eyes/src/files.rs", "animate", 122),
    ("crates/derma-eyes/src/glb.rs", "write", 299),
    ("crates/derma-eyes/src/live.rs", "pack", 150),
    ("crates/derma-eyes/src/region.rs", "build", 187),
    ("crates/derma-head/src/regions.rs", "weights", 192),
    ("crates/derma-head/src/subdivision.rs", "catmull_clark", 123),
    ("crates/derma-optics/src/gpu.rs", "run_gpu_with", 210),
    ("crates/derma-optics/src/transport.rs", "trace", 162),
    ("crates/derma-optics/src/transport_lanes.rs", "walk", 273),
    ("crates/derma-photo/src/bake.rs", "bake", 498),
    ("crates/derma-photo/src/chromophores.rs", "invert_with", 157),
    ("crates/derma-photo/src/iris.rs", "iris_texture", 180),
    ("crates/derma-photo/src/register.rs", "register", 129),
    ("crates/derma-photo/src/register.rs", "refine", 129),
    ("crates/derma-photo/src/resection.rs", "dlt", 128),
    ("crates/derma-photo/src/resection.rs", "refine", 132),
    ("crates/derma-photo/src/resection.rs", "resect", 138),
    ("crates/derma-photo/src/teeth.rs", "teeth_texture", 159),
    ("crates/derma-photo/src/unwrap.rs", "unwrap", 164),
    ("crates/derma-render/src/draw.rs", "draw", 152),
    ("crates/derma-render/src/renderer.rs", "new", 242),
    ("crates/derma-render/src/renderer.rs", "upload", 156),
    ("crates/derma-render/src/renderer.rs", "submit_frame", 182),
    (
        "crates/derma-shading/src/match_report.rs",
        "write_plots",
        174,
    ),
    ("crates/derma-skin/src/builtin_head.rs", "fields_on", 169),
    ("crates/derma-skin/src/generate.rs", "generate", 242),
    ("crates/derma-skin/src/generate.rs", "write_files", 139),
    ("crates/derma-skin/src/texture_set.rs", "write_maps", 192),
    ("crates/derma-synth/src/gpu.rs", "run", 227),
    (
        "crates/derma-synth/src/gpu_patch_pass.rs",
        "patch_pass_resident",
        252,
    ),
    ("crates/derma-synth/src/search.rs", "scan_pruned_body", 147),
];

#[test]
fn functions_stay_short_and_long_ones_only_shrink() {
    let root = workspace();
    let mut found = Vec::new();
    for krate in crates() {
        for f in rust_files(&krate.join("src")) {
            let rel = f
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            for (name, n) in function_lengths(&std::fs::read_to_string(&f).unwrap()) {
                if n > MAX_FUNCTION_LINES {
                    found.push((rel.clone(), name, n));
                }
            }
        }
    }
    let mut bad = Vec::new();
    for (file, name, n) in &found {
        match LONG_FUNCTIONS
            .iter()
            .find(|(f, m, _)| f == file && m == name)
        {
            Some((_, _, was)) if n <= was => {}
            Some((_, _, was)) => {
                bad.push(format!("{file}: fn {name} grew to {n} lines (was {was})"))
            }
            None => bad.push(format!(
                "{file}: fn {name} has {n} lines (new functions ≤ {MAX_FUNCTION_LINES})"
            )),
        }
    }
    for (file, name, _) in LONG_FUNCTIONS {
        if !found.iter().any(|(f, m, _)| f == file && m == name) {
            bad.push(format!(
                "{file}: fn {name} is short now (or gone): take it off LONG_FUNCTIONS"
            ));
        }
    }
    if !bad.is_empty() {
        let list: Vec<String> = found
            .iter()
            .map(|(f, m, n)| format!("    (\"{f}\", \"{m}\", {n}),"))
            .collect();
        panic!(
            "{}\n\ntoday's long functions:\n{}",
            bad.join("\n"),
            list.join("\n")
        );
    }
}

#[test]
fn the_function_counter_counts_and_the_ratchet_can_fail() {
    // A 130-line function, one with a brace in a string and a comment, and a trait's
    // declaration without a body.
    let body = "    let x = 1;\n".repeat(128);
    let src = format!(
        "fn long() {{\n{body}}}\n\nfn short(a: [f32; 3]) -> u8 {{\n    let s = \"}}\"; // {{\n    0\n}}\ntrait T {{\n    fn declared(&self);\n}}\n"
    );
    let f = function_lengths(&src);
    assert_eq!(
        f,
        vec![("long".to_string(), 130), ("short".to_string(), 4)],
        "{f:?}"
    );
    assert!(f[0].1 > MAX_FUNCTION_LINES);
}
