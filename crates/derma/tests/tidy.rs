//! The architecture's invariants as a test, after rust-analyzer's `tidy`: ARCHITECTURE.md states
//! them, this file checks each over the source tree, so a change that breaks one fails here.
//! Each check is a finder over text (sources, manifests, file lists) that returns what breaks
//! the rule, run on the tree by one test and on a planted violation by another (`the_…_finds_…`),
//! so every check is shown able to fail:
//!
//! - every CLI file is under 300 lines, and a flag parser two CLI files use lives in `args.rs`;
//! - no library prints (`print!`, `println!`, `eprint!`, `eprintln!`, `dbg!` outside tests) or
//!   declares `indicatif`; no library's string names a CLI `--flag`;
//! - every crate opens with a crate doc naming its sources and every module with a doc comment
//!   of two lines or more; every library's root has `#![warn(missing_docs)]`;
//! - no import circles between the modules of any crate; every crate sits above its derma
//!   dependencies in ARCHITECTURE.md's table and uses exactly those its row lists;
//! - every dependency is declared once, in the workspace, and used; the GPU is an optional
//!   feature, off by default, and no manifest declares a linear-algebra library;
//! - derma-core returns only its own errors; no library has a free-text `Invalid(String)`;
//! - every public function that reads a file is called by a property test (`proptest!` in its
//!   crate's `tests/robust_*.rs`);
//! - every test file of a one-binary crate (`autotests = false`) is declared in `tests/suite.rs`;
//! - CPU images are shaded in derma-render's one frame (`Env::new` and `brdf::` nowhere else but
//!   a listed exception that may only shrink);
//! - the test files and tests ARCHITECTURE.md cites exist;
//! - functions stay short, and the long ones only shrink.
//!
//! The module graph: a node per source file, the crate root included; an arrow from a file to
//! every module a path in its non-test code resolves to (`crate::`, `super::`, `self::` or a
//! child's name), following `pub use` re-exports to the module that defines the item. A file's
//! facade (`mod` declarations, `pub use` of its own submodules: all of the crate root's) is
//! containment, not an import; a `pub use` of a sibling's or a parent's item is an import.
//!
//! A file reader: a function that takes a path (`&Path`, `impl AsRef<Path>`, `PathBuf`), returns a
//! `Result` and reads the file — itself (`std::fs`, `File::open`, TOML or JSON parsing), through
//! a private function of its crate that does, or through a derma-core reader (`Dtab::read`,
//! `image_io::read_rgb`, `TriMesh::load`…).

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
    /// Every path a module re-exports (`pub use`), absolute.
    reexported: BTreeMap<Vec<String>, Vec<Vec<String>>>,
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
            reexported: BTreeMap::new(),
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
            let mut targets = Vec::new();
            for tree in reexported(&code) {
                let mut acc = Vec::new();
                expand(tree, 0, &[], &mut acc);
                for p in acc {
                    let (Some(last), Some(t)) = (p.last().cloned(), c.absolute(&m, &p)) else {
                        continue;
                    };
                    targets.push(t.clone());
                    map.insert(last, t);
                }
            }
            c.reexports.insert(m.clone(), map);
            c.reexported.insert(m, targets);
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
    /// and `pub use` re-exports of its own descendants — is containment, not an import; every
    /// other path in its code is an arrow, to a sibling, a parent or a child alike (the crate
    /// root is a module too), a `pub use` of a sibling's or a parent's item included.
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
            for abs in self.reexported.get(m).into_iter().flatten() {
                let t = self.resolve(abs, 0);
                if !abs.starts_with(m) && &t != m {
                    set.insert(t);
                }
            }
        }
        g
    }
}

/// The use trees of the `pub use` and `pub(crate) use` statements in comment-free `code`
/// (`a::{b, c}` of `pub use a::{b, c};`), each starting a line.
fn reexported(code: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut at = 0;
    for line in code.split_inclusive('\n') {
        let t = line.trim_start();
        let start = at + line.len() - t.len();
        at += line.len();
        for p in ["pub use ", "pub(crate) use "] {
            if t.starts_with(p) {
                let rest = &code[start + p.len()..];
                out.push(rest[..rest.find(';').unwrap_or(rest.len())].trim());
            }
        }
    }
    out
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

#[test]
fn the_circle_finder_counts_a_modules_pub_use_as_an_import() {
    // `pub use crate::rng::Philox` in `numerics` is an arrow numerics → rng; the root's facade
    // and a module's re-export of its own child are containment.
    let dir = std::env::temp_dir().join(format!("derma-tidy-use-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("src/numerics")).unwrap();
    let put = |path: &str, text: &str| std::fs::write(dir.join(path), text).unwrap();
    put("Cargo.toml", "[package]\nname = \"x\"\n");
    put(
        "src/lib.rs",
        "//! x\npub mod rng;\npub mod numerics;\npub use rng::Philox;\npub use crate::numerics::lanes::Lanes;\npub struct Seed;\n",
    );
    put(
        "src/numerics/mod.rs",
        "//! n\npub mod lanes;\npub use self::lanes::Lanes;\npub use crate::rng::Philox;\npub struct Grid;\n",
    );
    put(
        "src/numerics/lanes.rs",
        "//! l\npub struct Lanes;\nfn f() { let _ = super::Grid; }\n",
    );
    put(
        "src/rng.rs",
        "//! r\npub struct Philox;\nfn f() { let _ = (crate::numerics::Grid, crate::Seed); }\n",
    );
    let found = circles(&Crate::load(&dir).graph());
    assert_eq!(
        found,
        vec![vec![vec!["numerics".to_string()], vec!["rng".to_string()]]]
    );
    put(
        "src/numerics/mod.rs",
        "//! n\npub mod lanes;\npub use self::lanes::Lanes;\npub struct Grid;\n",
    );
    let found = circles(&Crate::load(&dir).graph());
    let _ = std::fs::remove_dir_all(&dir);
    assert!(found.is_empty(), "{found:?}");
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

/// Every `.rs` file below `dir` with its text, named from the workspace's root.
fn sources(dir: &Path) -> Vec<(String, String)> {
    let root = workspace();
    rust_files(dir)
        .into_iter()
        .map(|f| {
            let rel = f.strip_prefix(&root).unwrap_or(&f).to_string_lossy();
            let text = std::fs::read_to_string(&f).unwrap();
            (rel.replace('\\', "/"), text)
        })
        .collect()
}

/// A crate's `Cargo.toml`.
fn manifest_of(krate: &Path) -> String {
    std::fs::read_to_string(krate.join("Cargo.toml")).unwrap()
}

/// The files of `files` (name, text) with `max` lines or more.
fn long_files(files: &[(String, String)], max: usize) -> Vec<String> {
    files
        .iter()
        .map(|(f, text)| (f, text.lines().count()))
        .filter(|&(_, n)| n >= max)
        .map(|(f, n)| format!("{f} has {n} lines"))
        .collect()
}

#[test]
fn cli_files_are_under_300_lines() {
    let long = long_files(&sources(&workspace().join("crates/derma/src")), 300);
    assert_none(
        &long,
        "CLI files must stay under 300 lines (parse → call → print):",
    );
}

#[test]
fn the_line_counter_finds_a_long_cli_file() {
    let files = [
        ("src/long.rs".to_string(), "fn f() {}\n".repeat(300)),
        ("src/short.rs".to_string(), "fn f() {}\n".repeat(299)),
    ];
    assert_eq!(long_files(&files, 300), ["src/long.rs has 300 lines"]);
}

/// The flag parsers (`value_parser = NAME`) of the CLI's `files` that do not live once in
/// `args.rs`: one defined in two files, or defined in one file and used by another.
fn stray_flag_parsers(files: &[(String, String)]) -> Vec<String> {
    let code: Vec<(&str, String)> = files
        .iter()
        .map(|(f, src)| (f.as_str(), non_test_code(src)))
        .collect();
    let parsers = |code: &str| -> BTreeSet<String> {
        let mut out = BTreeSet::new();
        for (i, _) in code.match_indices("value_parser") {
            let rest = code[i + "value_parser".len()..].trim_start();
            let Some(path) = rest.strip_prefix('=') else {
                continue;
            };
            let path: String = path
                .trim_start()
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                .collect();
            if let Some(name) = path.rsplit("::").next().filter(|n| !n.is_empty()) {
                out.insert(name.to_string());
            }
        }
        out
    };
    let used: Vec<(&str, BTreeSet<String>)> = code.iter().map(|(f, c)| (*f, parsers(c))).collect();
    let mut found = Vec::new();
    for name in used.iter().flat_map(|(_, u)| u).collect::<BTreeSet<_>>() {
        let homes: Vec<&str> = code
            .iter()
            .filter(|(_, c)| has_word(c, &format!("fn {name}(")))
            .map(|(f, _)| *f)
            .collect();
        let users: Vec<&str> = used
            .iter()
            .filter(|(_, u)| u.contains(name))
            .map(|(f, _)| *f)
            .collect();
        match homes.as_slice() {
            [] => {} // another crate's parser
            [home] if home.ends_with("/args.rs") || users.iter().all(|u| u == home) => {}
            _ => found.push(format!(
                "{name}: defined in {}, used by {}; a shared flag parser lives once, in args.rs",
                homes.join(", "),
                users.join(", ")
            )),
        }
    }
    found
}

#[test]
fn shared_flag_parsers_live_in_args() {
    let found = stray_flag_parsers(&sources(&workspace().join("crates/derma/src")));
    assert_none(&found, "flag parsers shared by CLI files outside args.rs:");
}

#[test]
fn the_parser_finder_finds_a_shared_parser_outside_args() {
    let files = |render: &str| {
        [
            (
                "src/args.rs".to_string(),
                "fn size(s: &str) -> Result<u32, String> { todo!() }\n".to_string(),
            ),
            (
                "src/skin.rs".to_string(),
                "struct A { #[arg(long, value_parser = crate::args::size)] s: u32,\n\
                 #[arg(long, value_parser = parse_preset)] p: P }\n\
                 fn parse_preset(s: &str) -> Result<P, String> { todo!() }\n"
                    .to_string(),
            ),
            ("src/render.rs".to_string(), render.to_string()),
        ]
    };
    let own = "struct B { #[arg(long, value_parser = parse_setup)] s: S }\nfn parse_setup(s: &str) -> Result<S, String> { todo!() }\n";
    assert!(stray_flag_parsers(&files(own)).is_empty());
    let shared = "struct B { #[arg(long, value_parser = crate::skin::parse_preset)] p: P }\n";
    let found = stray_flag_parsers(&files(shared));
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].starts_with(
            "parse_preset: defined in src/skin.rs, used by src/skin.rs, src/render.rs"
        ),
        "{found:?}"
    );
    let twice = "struct B { #[arg(long, value_parser = size)] s: u32 }\nfn size(s: &str) -> Result<u32, String> { todo!() }\n";
    let found = stray_flag_parsers(&files(twice));
    assert!(
        found.len() == 1 && found[0].starts_with("size: defined in src/args.rs, src/render.rs"),
        "{found:?}"
    );
}

/// CPU shading loops outside the frame that ARCHITECTURE.md names under "not yet what it should
/// be": this list may only shrink. derma-photo's synthetic photos keep the Lambertian world
/// de-lighting's models describe (the renderer's shading adds a sky reflection none holds).
const KNOWN_SHADINGS: &[&str] = &["crates/derma-photo/src/synthetic.rs"];

/// The files of `files` (name, text) whose non-test code shades on the CPU outside the one
/// frame: sets up the lights (`Env::new`) or evaluates the microfacet terms (`brdf::`) anywhere
/// but derma-render's `frame.rs`, `shade.rs` and `brdf.rs` (and `renderer.rs`, the GPU's loop,
/// which prepends brdf.wgsl to its shaders), or [`KNOWN_SHADINGS`].
fn stray_shading(files: &[(String, String)]) -> Vec<String> {
    let home = ["frame.rs", "shade.rs", "brdf.rs", "renderer.rs"]
        .map(|f| format!("crates/derma-render/src/{f}"));
    files
        .iter()
        .filter(|(f, _)| !home.contains(f) && !KNOWN_SHADINGS.contains(&f.as_str()))
        .filter_map(|(f, src)| {
            let code = non_test_code(src);
            let hit = ["Env::new(", "brdf::"]
                .into_iter()
                .find(|p| code.contains(p))?;
            Some(format!("{f}: {hit}"))
        })
        .collect()
}

#[test]
fn the_cpu_shades_in_one_frame() {
    let files: Vec<(String, String)> = libraries()
        .iter()
        .flat_map(|k| sources(&k.join("src")))
        .collect();
    assert_none(
        &stray_shading(&files),
        "CPU images are shaded by derma-render's frame (G-buffer, steps, shade::Env) alone:",
    );
}

#[test]
fn the_shading_finder_finds_a_second_shading_loop() {
    let file = |f: &str, src: &str| (f.to_string(), src.to_string());
    let files = [
        file(
            "crates/derma-render/src/frame.rs",
            "fn f() { Env::new(l, g); }",
        ),
        file(
            "crates/derma-photo/src/bake.rs",
            "fn f() { brdf::specular(n, l, v, a, f0) }",
        ),
        file(
            "crates/derma-eyes/src/lake.rs",
            "fn f() { let e = Env::new(l, g); }",
        ),
        file(
            "crates/derma-eyes/src/ok.rs",
            "fn f() {}\n#[cfg(test)]\nmod tests { fn t() { Env::new(l, g); } }",
        ),
    ];
    assert_eq!(
        stray_shading(&files),
        [
            "crates/derma-photo/src/bake.rs: brdf::",
            "crates/derma-eyes/src/lake.rs: Env::new(",
        ]
    );
}

/// The lines of `src` (tests left out) that call a printing macro a library must not call.
fn prints(src: &str) -> Vec<usize> {
    let code = non_test_code(src);
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

/// Whether a manifest declares `dep` in any of its dependency tables.
fn declares(manifest: &str, dep: &str) -> bool {
    [
        "dependencies",
        "dev-dependencies",
        "build-dependencies",
        "workspace.dependencies",
    ]
    .iter()
    .any(|t| dependencies(manifest, t).iter().any(|d| d == dep))
}

#[test]
fn libraries_never_print() {
    let mut found = Vec::new();
    for k in libraries() {
        if name_of(&k) == "derma-test-support" {
            continue; // the tests' own helpers say why a test skipped
        }
        for (f, src) in sources(&k.join("src")) {
            for line in prints(&src) {
                found.push(format!("{f}:{line}"));
            }
        }
        if declares(&manifest_of(&k), "indicatif") {
            found.push(format!("{}: declares indicatif", name_of(&k)));
        }
    }
    assert_none(
        &found,
        "libraries report through derma_core::progress, never print; only the CLI draws progress:",
    );
}

#[test]
fn the_print_finder_finds_prints_and_progress_bars() {
    let src = "fn f() {\n    let n = 1;\n    eprintln!(\"{n}\");\n    dbg!(n);\n    let s = \"println!\";\n    my_print!(n);\n}\n#[cfg(test)]\nmod tests { fn t() { println!(\"ok\"); } }\n";
    assert_eq!(prints(src), [3, 4]);
    assert!(declares(
        "[dependencies]\nindicatif.workspace = true\n",
        "indicatif"
    ));
    assert!(!declares(
        "[dependencies]\nderma-core.workspace = true\n",
        "indicatif"
    ));
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
        for (f, src) in sources(&k.join("src")) {
            for hit in flags_named(&src) {
                found.push(format!("{f}:{hit}"));
            }
        }
    }
    assert_none(
        &found,
        "a library's errors and notes name the value or option, and the CLI names its flag:",
    );
}

#[test]
fn the_flag_finder_finds_a_flag_in_a_message() {
    // A flag in a message, and none in a test or a peer's command line.
    let probe = "fn f() -> String { \"choose a smaller --size\".into() }\n\
                 fn g() -> &'static str { \"sbatch --array=1-4\" }\n\
                 #[cfg(test)]\nmod tests { fn t() { let _ = \"--size 8\"; } }\n";
    assert_eq!(flags_named(probe), ["1: \"choose a smaller --size\""]);
}

/// The leading `//!` lines of a file.
fn module_doc(src: &str) -> Vec<&str> {
    src.lines().take_while(|l| l.starts_with("//!")).collect()
}

/// What a file's docs lack: every module opens with two lines or more of `//!` on what it
/// models, and a crate's root (`root`) names its sources too.
fn thin_docs(src: &str, root: bool) -> Vec<&'static str> {
    let doc = module_doc(src);
    let text: String = doc
        .iter()
        .map(|l| l.trim_start_matches("//!").trim())
        .collect::<Vec<_>>()
        .join(" ");
    let mut out = Vec::new();
    if doc.len() < 2 || text.split_whitespace().count() < 12 {
        out.push("a module opens with at least two lines of `//!` on what it models");
    }
    if root && !cites_a_source(&text) {
        out.push("the crate doc names its sources (a paper with its year, a thesis, docs/…, the seeds or a PROVENANCE file)");
    }
    out
}

#[test]
fn every_crate_and_module_says_what_it_models() {
    let mut missing = Vec::new();
    for k in crates() {
        for (f, src) in sources(&k.join("src")) {
            let root = (f.ends_with("src/lib.rs") || f.ends_with("src/main.rs"))
                && name_of(&k) != "derma-test-support";
            for lack in thin_docs(&src, root) {
                missing.push(format!("{f}: {lack}"));
            }
        }
    }
    assert_none(&missing, "modules and crates without the docs they need:");
}

#[test]
fn the_doc_finder_finds_thin_docs() {
    let good = "//! Light in layered skin: Monte Carlo transport after BioSpec (Krishnaswamy and\n//! Baranoski 2004), on the CPU and the GPU.\n";
    assert!(thin_docs(good, true).is_empty());
    assert_eq!(
        thin_docs(
            "//! One line on what this models, however long it may be.\nfn f() {}\n",
            false
        )
        .len(),
        1
    );
    assert_eq!(thin_docs("fn f() {}\n", false).len(), 1);
    let unsourced = "//! Light in layered skin: Monte Carlo transport after BioSpec, on the CPU\n//! and on the GPU, with tallies.\n";
    assert!(thin_docs(unsourced, false).is_empty());
    assert_eq!(thin_docs(unsourced, true), [thin_docs("", true)[1]]);
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

/// The dependencies a manifest declares and its code never uses, as `[table] name`: `src` is the
/// comment-free code of `src` (tests out), `all` that of `src`, `tests`, `benches`, `examples`.
fn unused_dependencies(manifest: &str, src: &str, all: &str) -> Vec<String> {
    let mut unused = Vec::new();
    for (table, text) in [("dependencies", src), ("dev-dependencies", all)] {
        for dep in dependencies(manifest, table) {
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
                unused.push(format!("[{table}] {dep}"));
            }
        }
    }
    unused
}

#[test]
fn every_declared_dependency_is_used() {
    let mut unused = Vec::new();
    for k in crates() {
        // Code only (a comment naming a crate is no use of it), test modules out of `src`.
        let src: String = sources(&k.join("src"))
            .iter()
            .map(|(_, s)| non_test_code(s))
            .collect();
        let all: String = ["src", "tests", "benches", "examples"]
            .iter()
            .flat_map(|d| sources(&k.join(d)))
            .map(|(_, s)| strip_comments_and_strings(&s))
            .collect::<Vec<_>>()
            .join("\n");
        for dep in unused_dependencies(&manifest_of(&k), &src, &all) {
            unused.push(format!("{}: {dep}", name_of(&k)));
        }
    }
    assert_none(&unused, "declared but never used:");
}

#[test]
fn the_dependency_finder_finds_an_unused_dependency() {
    let manifest = "[dependencies]\nglam.workspace = true\nrayon.workspace = true\nserde_json.workspace = true\n\n[dev-dependencies]\nproptest.workspace = true\n";
    let src =
        "use glam::Vec3;\nfn f() { let _ = serde_json::json!({}); }\n// rayon:: in a comment\n";
    let found = unused_dependencies(manifest, &non_test_code(src), "use exr_writer::X;");
    assert_eq!(
        found,
        ["[dependencies] rayon", "[dev-dependencies] proptest"]
    );
}

/// A function of comment- and string-free code: its name, whether it is `pub` (not
/// `pub(crate)`), the byte ranges of its signature and its body, and the type whose `impl`
/// block holds it.
struct Function {
    name: String,
    public: bool,
    signature: std::ops::Range<usize>,
    body: std::ops::Range<usize>,
    owner: Option<String>,
}

/// The `impl` blocks of comment-free `code` (each starting a line): their ranges and types.
fn impl_blocks(code: &str) -> Vec<(std::ops::Range<usize>, String)> {
    let mut out = Vec::new();
    let mut at = 0;
    for line in code.split_inclusive('\n') {
        let t = line.trim_start();
        let start = at + line.len() - t.len();
        at += line.len();
        let Some(mut head) = t.strip_prefix("impl").filter(|r| r.starts_with([' ', '<'])) else {
            continue;
        };
        head = &head[..head.find('{').unwrap_or(head.len())];
        if head.starts_with('<') {
            // Past the generics: `impl<'a, T: Tr<U>> Ty<'a> {`.
            let mut depth = 0;
            let close = head.char_indices().find(|&(_, c)| {
                depth += (c == '<') as i32 - (c == '>') as i32;
                depth == 0
            });
            head = &head[close.map_or(head.len(), |(i, _)| i + 1)..];
        }
        let ty = head.rsplit(" for ").next().unwrap_or(head);
        let ty = ty.split('<').next().unwrap_or(ty).trim();
        let ty = ty.rsplit("::").next().unwrap_or(ty);
        out.push((start..item_end(code.as_bytes(), start), ty.to_string()));
    }
    out
}

/// Every function with a body in comment- and string-free `code`.
fn functions(code: &str) -> Vec<Function> {
    let b = code.as_bytes();
    let impls = impl_blocks(code);
    let mut out = Vec::new();
    let mut at = 0;
    while let Some(p) = code[at..].find("fn ") {
        let start = at + p;
        at = start + 3;
        if start > 0 && (b[start - 1].is_ascii_alphanumeric() || b[start - 1] == b'_') {
            continue;
        }
        let name: String = code[start + 3..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let end = item_end(b, start);
        if name.is_empty() || b[end - 1] != b'}' {
            continue;
        }
        // The body opens at the first `{` outside brackets.
        let mut depth = 0i32;
        let brace = (start..end)
            .find(|&i| {
                match b[i] {
                    b'(' | b'[' => depth += 1,
                    b')' | b']' => depth -= 1,
                    _ => {}
                }
                b[i] == b'{' && depth == 0
            })
            .unwrap_or(end);
        let mut before = code[..start].trim_end();
        while let Some(b) = ["const", "async", "unsafe"]
            .iter()
            .find_map(|q| before.strip_suffix(q))
        {
            before = b.trim_end();
        }
        out.push(Function {
            name,
            public: before.ends_with("pub"),
            signature: start..brace,
            body: brace..end,
            owner: impls
                .iter()
                .filter(|(r, _)| r.contains(&start))
                .map(|(_, t)| t.clone())
                .next_back(),
        });
    }
    out
}

/// Whether a signature takes a path (`&Path`, `impl AsRef<Path>`, `PathBuf`, among its
/// parameters or bounds) and returns a `Result` (a reader says a file is bad by its error).
fn takes_a_path_and_may_fail(sig: &str) -> bool {
    // The parameters end at the `)` that closes the first `(` after the name and generics.
    let b = sig.as_bytes();
    let (mut angle, mut paren) = (0i32, 0i32);
    let mut close = sig.len();
    for i in 0..b.len() {
        match b[i] {
            b'<' => angle += 1,
            b'>' if i > 0 && b[i - 1] == b'-' => {}
            b'>' => angle -= 1,
            b'(' => paren += 1,
            b')' => {
                paren -= 1;
                if paren == 0 && angle == 0 {
                    close = i;
                    break;
                }
            }
            _ => {}
        }
    }
    let (ret, bounds) = sig[close..]
        .split_once(" where ")
        .unwrap_or((&sig[close..], ""));
    let path = |t: &str| is_word(t, "Path") || is_word(t, "PathBuf");
    (path(&sig[..close]) || path(bounds)) && ret.contains("Result")
}

/// Whether `word` occurs in `text` as a whole identifier.
fn is_word(text: &str, word: &str) -> bool {
    let b = text.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    text.match_indices(word).any(|(i, _)| {
        (i == 0 || !ident(b[i - 1])) && b.get(i + word.len()).is_none_or(|&c| !ident(c))
    })
}

/// Whether `code` calls `callee` (`Dtab::read`, `read_rgb`): the name, then `(` or `::<`.
fn calls(code: &str, callee: &str) -> bool {
    let b = code.as_bytes();
    code.match_indices(callee).any(|(i, _)| {
        let after = code[i + callee.len()..].trim_start();
        (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_'))
            && (after.starts_with('(') || after.starts_with("::<"))
    })
}

/// What reads a file or parses its text: a function that takes a path and does one of these
/// reads it.
const READS: &[&str] = &[
    "fs::read(",
    "fs::read_to_string(",
    "File::open(",
    "toml::from_str",
    "serde_json::from_",
    "read_json(",
    "image::open(",
    "_from_file(",
    "tobj::load_obj(",
    "gltf::import(",
];

/// A function that reads a file: where, its name, whether it is public, and how other files
/// call it (`Dtab::read`, `image_io::read_rgb`, `read_rgb`).
#[derive(Clone, Debug)]
struct Reader {
    file: String,
    name: String,
    public: bool,
    called_as: Vec<String>,
}

/// The functions of one crate's `files` (name, source; tests left out) that take a path, return
/// a `Result` and read the file: directly ([`READS`]), through a reader named in `via` (derma-
/// core's), or through one of the crate's own: a private one always, a public one only
/// `through_public` (else it is a reader of its own, tested on its own).
fn file_readers(files: &[(String, String)], via: &[String], through_public: bool) -> Vec<Reader> {
    let parsed: Vec<(&str, String, String, Vec<Function>)> = files
        .iter()
        .map(|(f, src)| {
            let p = Path::new(f);
            let stem = p.file_stem().unwrap().to_string_lossy();
            let module = if stem == "mod" {
                p.parent().unwrap().file_name().unwrap().to_string_lossy()
            } else {
                stem
            };
            let code = non_test_code(src);
            let fns = functions(&code);
            (f.as_str(), module.into_owned(), code, fns)
        })
        .collect();
    let mut callees: Vec<String> = via.to_vec();
    let mut found: Vec<Reader> = Vec::new();
    loop {
        let before = found.len();
        for (file, module, code, fns) in &parsed {
            // In its own file a reader is called by its name alone, or through `Self::`.
            let here: Vec<String> = found
                .iter()
                .filter(|r| r.file == *file && (through_public || !r.public))
                .flat_map(|r| [r.name.clone(), format!("Self::{}", r.name)])
                .collect();
            for f in fns {
                if found.iter().any(|r| r.file == *file && r.name == f.name) {
                    continue;
                }
                let body = &code[f.body.clone()];
                let reads = READS.iter().any(|p| has_word(body, p))
                    || callees.iter().chain(&here).any(|c| calls(body, c));
                if !reads || !takes_a_path_and_may_fail(&code[f.signature.clone()]) {
                    continue;
                }
                let owner = f.owner.as_deref().unwrap_or(module);
                let mut called_as = vec![format!("{owner}::{}", f.name)];
                if f.owner.is_none() && f.name.contains('_') {
                    called_as.push(f.name.clone());
                }
                if through_public || !f.public {
                    callees.extend(called_as.iter().cloned());
                }
                found.push(Reader {
                    file: file.to_string(),
                    name: f.name.clone(),
                    public: f.public,
                    called_as,
                });
            }
        }
        if found.len() == before {
            return found;
        }
    }
}

/// The public readers of `readers` that no robust test calls (as its type's or module's
/// function, or by a name with an underscore alone): `robust` is the text of the crate's
/// `tests/robust_*.rs` files, those with a `proptest!` count.
fn untested_readers(readers: &[Reader], robust: &[String]) -> Vec<String> {
    let code: Vec<String> = robust
        .iter()
        .filter(|t| t.contains("proptest!"))
        .map(|t| strip_comments_and_strings(t))
        .collect();
    let tested = |r: &Reader, c: &str| {
        r.called_as.iter().any(|q| calls(c, q)) || r.name.contains('_') && calls(c, &r.name)
    };
    readers
        .iter()
        .filter(|r| r.public && !code.iter().any(|c| tested(r, c)))
        .map(|r| format!("{}: fn {}", r.file, r.name))
        .collect()
}

/// The text of a crate's `tests/robust_*.rs` files.
fn robust_tests(krate: &Path) -> Vec<String> {
    sources(&krate.join("tests"))
        .into_iter()
        .filter(|(f, _)| {
            Path::new(f)
                .file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("robust_")
        })
        .map(|(_, text)| text)
        .collect()
}

#[test]
fn every_crate_that_reads_files_has_property_tests() {
    // derma-core's readers, through each other: how the other crates read files.
    let core = sources(&workspace().join("crates/derma-core/src"));
    let via: Vec<String> = file_readers(&core, &[], true)
        .into_iter()
        .filter(|r| r.public)
        .flat_map(|r| r.called_as)
        .collect();
    let mut missing = Vec::new();
    for k in libraries() {
        let readers = if name_of(&k) == "derma-core" {
            file_readers(&core, &[], false)
        } else {
            file_readers(&sources(&k.join("src")), &via, false)
        };
        missing.extend(untested_readers(&readers, &robust_tests(&k)));
    }
    assert_none(
        &missing,
        "public functions that read files without a property test of bad files (a tests/robust_*.rs with proptest! that calls them):",
    );
}

#[test]
fn the_reader_finder_finds_an_untested_reader() {
    let core = [(
        "crates/derma-core/src/dtab.rs".to_string(),
        "impl Dtab {\n    pub fn read(path: &Path) -> Result<Self> {\n        let b = std::fs::read(path)?;\n        Self::parse(&b, path)\n    }\n}\n".to_string(),
    )];
    let via: Vec<String> = file_readers(&core, &[], true)
        .into_iter()
        .flat_map(|r| r.called_as)
        .collect();
    assert_eq!(via, ["Dtab::read"]);
    let src = "\
pub fn table(path: &Path) -> Result<T> { T::new(derma_core::dtab::Dtab::read(path)?) }
pub fn config(path: impl AsRef<Path>) -> Result<C> { let t = text_of(path.as_ref())?; parse(&t) }
pub fn grid(text: &str, path: &Path) -> Result<G> { toml::from_str(text).map_err(|e| bad(path, e)) }
fn text_of(path: &Path) -> Result<String> { Ok(std::fs::read_to_string(path)?) }
pub fn store(dir: &Path) -> Result<S> { let (s, _) = head_json::<S>(dir)?; Ok(s) }
fn head_json<T>(dir: &Path) -> Result<(T, PathBuf)> { let b = std::fs::read(dir.join(\"head.json\"))?; todo!() }
pub fn writes(dir: &Path, bytes: &[u8]) -> Result<()> { Ok(std::fs::write(dir, bytes)?) }
pub fn named(&self) -> Result<PathBuf> { let _ = std::fs::read(\"x\"); todo!() }
pub fn hash(path: &Path) -> Option<String> { std::fs::read(path).ok().map(sha) }
pub fn again(path: &Path) -> Result<T> { table(path) }
";
    let files = [("crates/x/src/store.rs".to_string(), src.to_string())];
    let readers = file_readers(&files, &via, false);
    let names: Vec<(&str, bool)> = readers
        .iter()
        .map(|r| (r.name.as_str(), r.public))
        .collect();
    assert_eq!(
        names,
        [
            ("table", true),
            ("grid", true),
            ("text_of", false),
            ("head_json", false),
            ("config", true),
            ("store", true)
        ]
    );
    // Called as its module's function it is tested; a bare `grid(` or another `store` is not.
    let robust = ["use proptest::prelude::*;\nproptest! { #[test] fn t(b in any::<u8>()) { let _ = (x::store::table(&p(b)), grid(\"\", &p(b)), other::store(&p(b))); } }\n// store::config( in a comment\n".to_string()];
    let found = untested_readers(&readers, &robust);
    assert_eq!(
        found,
        [
            "crates/x/src/store.rs: fn grid",
            "crates/x/src/store.rs: fn config",
            "crates/x/src/store.rs: fn store"
        ]
    );
    // A robust file without proptest! is no property test.
    let plain = ["fn t() { store::table(p); }".to_string()];
    assert_eq!(untested_readers(&readers, &plain).len(), 4);
}

/// What a manifest does against the GPU's rule: every crate that declares `wgpu` declares it
/// optional, behind a `gpu` feature with `dep:wgpu` that turns on `derma-core/gpu` (derma-core's
/// own is the root); no default feature is the GPU; no table declares a linear-algebra library.
fn gpu_faults(name: &str, manifest: &str) -> Vec<String> {
    let mut wrong = Vec::new();
    let deps = table_lines(manifest, "dependencies");
    if let Some(w) = deps.iter().find(|t| t.starts_with("wgpu")) {
        if !w.contains("optional = true") {
            wrong.push(format!("{name}: wgpu is not optional ({w})"));
        }
        let gpu = table_lines(manifest, "features")
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
    for t in table_lines(manifest, "features") {
        if t.starts_with("default") && t.contains("gpu") {
            wrong.push(format!(
                "{name}: the default features include the GPU ({t})"
            ));
        }
    }
    for lib in ["faer", "nalgebra", "ndarray-linalg", "lapack"] {
        if declares(manifest, lib) {
            wrong.push(format!(
                "{name}: declares {lib} (numerics is derma-core's own)"
            ));
        }
    }
    wrong
}

#[test]
fn the_gpu_is_a_feature_and_off_by_default() {
    let mut wrong = Vec::new();
    for k in crates() {
        wrong.extend(gpu_faults(&name_of(&k), &manifest_of(&k)));
    }
    let root = std::fs::read_to_string(workspace().join("Cargo.toml")).unwrap();
    wrong.extend(gpu_faults("the workspace", &root));
    assert_none(&wrong, "the GPU stays a feature, off by default:");
}

#[test]
fn the_gpu_finder_finds_a_gpu_by_default() {
    let good = "[dependencies]\nwgpu = { workspace = true, optional = true }\n\n[features]\ngpu = [\"derma-core/gpu\", \"dep:wgpu\"]\n";
    assert!(gpu_faults("x", good).is_empty());
    let always = "[dependencies]\nwgpu.workspace = true\n\n[features]\ngpu = [\"dep:wgpu\"]\n";
    assert_eq!(
        gpu_faults("x", always).len(),
        2,
        "{:?}",
        gpu_faults("x", always)
    );
    let default = format!("{good}default = [\"gpu\"]\n");
    assert_eq!(
        gpu_faults("x", &default),
        ["x: the default features include the GPU (default = [\"gpu\"])"]
    );
    let algebra = "[workspace.dependencies]\nnalgebra = \"0.33\"\n";
    assert_eq!(
        gpu_faults("w", algebra),
        ["w: declares nalgebra (numerics is derma-core's own)"]
    );
}

/// A manifest's dependencies declared with a version of their own, not from the workspace.
fn local_declarations(manifest: &str) -> Vec<String> {
    ["dependencies", "dev-dependencies", "build-dependencies"]
        .iter()
        .flat_map(|table| table_lines(manifest, table))
        .filter(|t| !t.contains("workspace = true"))
        .map(str::to_string)
        .collect()
}

#[test]
fn every_dependency_is_declared_once_in_the_workspace() {
    let mut local = Vec::new();
    for k in crates() {
        for t in local_declarations(&manifest_of(&k)) {
            local.push(format!("{}: {t}", name_of(&k)));
        }
    }
    assert_none(
        &local,
        "declare versions once, in [workspace.dependencies]:",
    );
}

#[test]
fn the_declaration_finder_finds_a_local_version() {
    let m = "[dependencies]\nglam.workspace = true\nrayon = \"1.10\"\n\n[dev-dependencies]\ngltf = { workspace = true, features = [\"extras\"] }\nproptest = { version = \"1\" }\n";
    assert_eq!(
        local_declarations(m),
        ["rayon = \"1.10\"", "proptest = { version = \"1\" }"]
    );
}

/// derma-core's public functions in `src` that fail with another crate's error: through
/// `crate::Result<T>` or a `Result<T, E>` naming one of `own` they are its own.
fn foreign_errors(src: &str, own: &[&str]) -> Vec<String> {
    let code = non_test_code(src);
    let mut foreign = Vec::new();
    // Signatures span lines: join each `pub fn` up to its body.
    for (i, _) in code.match_indices("pub fn ") {
        let sig: String = code[i..]
            .chars()
            .take_while(|&c| c != '{' && c != ';')
            .collect();
        // The return type: after the last arrow before any `where` clause (a parameter may be
        // a closure with an arrow of its own).
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
        let first_line = sig.lines().next().unwrap_or("").to_string();
        if foreign_alias || ret.contains("io::Result") || ret.contains("fmt::Result") {
            foreign.push(first_line);
        } else if let Some(p) = ret.find("Result<") {
            let args = &ret[p + 7..];
            let mut d = 0i32;
            let comma = args.char_indices().find(|&(_, c)| {
                match c {
                    '<' | '(' | '[' => d += 1,
                    '>' | ')' | ']' => d -= 1,
                    _ => {}
                }
                c == ',' && d == 0
            });
            if let Some((k, _)) = comma {
                let err = args[k + 1..].trim_end_matches('>');
                let name = err.rsplit("::").next().unwrap_or(err);
                if !own.contains(&name) {
                    foreign.push(first_line);
                }
            }
        }
    }
    foreign
}

/// derma-core's own error types.
const CORE_ERRORS: [&str; 3] = ["CoreError", "GpuError", "NumericsError"];

#[test]
fn core_returns_only_its_own_errors() {
    let mut foreign = Vec::new();
    for (f, src) in sources(&workspace().join("crates/derma-core/src")) {
        for sig in foreign_errors(&src, &CORE_ERRORS) {
            foreign.push(format!("{f}: {sig}"));
        }
    }
    assert_none(&foreign, "derma-core functions returning other errors:");
}

#[test]
fn the_error_finder_finds_a_foreign_error() {
    let src = "\
pub fn ok(a: u8) -> Result<u8> { todo!() }
pub fn ours(a: u8) -> crate::Result<u8> { todo!() }
pub fn named(a: u8) -> Result<u8, crate::GpuError> { todo!() }
pub fn mapped<F: Fn(u8) -> u8>(f: F) -> Result<Vec<(u8, u8)>, NumericsError> { todo!() }
pub fn io(a: u8) -> std::io::Result<u8> { todo!() }
pub fn other(a: u8) -> Result<u8, image::ImageError> { todo!() }
pub fn alias(a: u8) -> anyhow::Result<u8> { todo!() }
#[cfg(test)]
mod tests { pub fn t() -> Result<(), String> { todo!() } }
";
    let found = foreign_errors(src, &CORE_ERRORS);
    assert_eq!(found.len(), 3, "{found:?}");
    assert!(found[0].starts_with("pub fn io") && found[2].starts_with("pub fn alias"));
}

/// ARCHITECTURE.md's crate table (`| floor | crate | uses | … |`, columns found by its header):
/// each crate's floor (none for `—`) and the derma crates it uses (`core, head`: derma-core and
/// derma-head; none without a `uses` column).
fn crate_table(arch: &str) -> BTreeMap<String, (Option<u32>, BTreeSet<String>)> {
    let mut table = BTreeMap::new();
    let mut columns: Option<(usize, usize, Option<usize>)> = None;
    for line in arch.lines() {
        if !line.starts_with('|') {
            columns = None; // the table ended
            continue;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let at = |name: &str| cells.iter().position(|c| *c == name);
        if let (Some(f), Some(c)) = (at("floor"), at("crate")) {
            columns = Some((f, c, at("uses")));
            continue;
        }
        let Some((f, c, u)) = columns else {
            continue;
        };
        let cell = |i: usize| cells.get(i).copied().unwrap_or("");
        let Some(name) = cell(c).strip_prefix('`').and_then(|n| n.strip_suffix('`')) else {
            continue;
        };
        let floor = cell(f).parse::<u32>().ok();
        if floor.is_none() && cell(f) != "—" {
            continue;
        }
        let uses = u
            .map(cell)
            .unwrap_or("")
            .split(',')
            .map(str::trim)
            .filter(|u| !u.is_empty() && *u != "—")
            .map(|u| format!("derma-{u}"))
            .collect();
        table.insert(name.to_string(), (floor, uses));
    }
    table
}

/// The derma crates a manifest depends on (`[dependencies]`).
fn derma_dependencies(manifest: &str) -> BTreeSet<String> {
    dependencies(manifest, "dependencies")
        .into_iter()
        .filter(|d| d.starts_with("derma"))
        .collect()
}

/// `name`'s dependencies on crates of its floor or above, by `table`.
fn off_floor(
    table: &BTreeMap<String, (Option<u32>, BTreeSet<String>)>,
    name: &str,
    manifest: &str,
) -> Vec<String> {
    let mine = match table.get(name) {
        None => {
            return vec![format!(
                "{name} is missing from ARCHITECTURE.md's crate table"
            )]
        }
        Some((None, _)) => return Vec::new(), // no floor: a dev-dependency only
        Some((Some(f), _)) => *f,
    };
    let mut wrong = Vec::new();
    for dep in derma_dependencies(manifest) {
        match table.get(&dep) {
            Some(&(Some(f), _)) if f < mine => {}
            Some(&(Some(f), _)) => wrong.push(format!(
                "{name} (floor {mine}) depends on {dep} (floor {f})"
            )),
            _ => wrong.push(format!("{name} depends on {dep}, which is in no floor")),
        }
    }
    wrong
}

/// Where `name`'s derma dependencies differ from the ones `table` lists for it: each one it
/// declares is listed, and each one listed is declared.
fn unlisted_uses(
    table: &BTreeMap<String, (Option<u32>, BTreeSet<String>)>,
    name: &str,
    manifest: &str,
) -> Vec<String> {
    let Some((_, listed)) = table.get(name) else {
        return vec![format!(
            "{name} is missing from ARCHITECTURE.md's crate table"
        )];
    };
    let declared = derma_dependencies(manifest);
    let mut wrong = Vec::new();
    for d in declared.difference(listed) {
        wrong.push(format!(
            "{name} depends on {d}, which its row does not list"
        ));
    }
    for d in listed.difference(&declared) {
        wrong.push(format!(
            "{name}'s row lists {d}, which its Cargo.toml does not declare"
        ));
    }
    wrong
}

/// The crate table of ARCHITECTURE.md, read and checked for size.
fn architecture_table() -> BTreeMap<String, (Option<u32>, BTreeSet<String>)> {
    let arch = std::fs::read_to_string(workspace().join("ARCHITECTURE.md")).unwrap();
    let table = crate_table(&arch);
    assert!(table.len() >= 14, "the crate table was not read: {table:?}");
    table
}

#[test]
fn crates_sit_on_their_floors() {
    let table = architecture_table();
    let mut wrong = Vec::new();
    for k in crates() {
        wrong.extend(off_floor(&table, &name_of(&k), &manifest_of(&k)));
    }
    assert_none(&wrong, "crates off their floors:");
}

#[test]
fn crates_use_only_the_crates_their_row_lists() {
    let table = architecture_table();
    let mut wrong = Vec::new();
    for k in crates() {
        wrong.extend(unlisted_uses(&table, &name_of(&k), &manifest_of(&k)));
    }
    assert_none(
        &wrong,
        "derma dependencies that differ from ARCHITECTURE.md's crate table (its `uses` column):",
    );
}

#[test]
fn the_floor_finders_find_a_crate_off_its_row() {
    let arch = "\
| floor | crate | uses | what it is |
|---|---|---|---|
| 0 | `derma-core` | — | shared |
| 1 | `derma-head` | core | the head |
| 2 | `derma-render` | core, head | drawing |
| 3 | `derma-shading` | core, render | shading |
| — | `derma-test-support` | core | helpers |
";
    let table = crate_table(arch);
    assert_eq!(table.len(), 5);
    assert!(
        crate_table("| floor | crate | what |\n|---|---|---|\n| 0 | `derma-core` | core |\n")
            ["derma-core"]
            .1
            .is_empty()
    );
    let render = "[dependencies]\nderma-core.workspace = true\nderma-head.workspace = true\nglam.workspace = true\n";
    assert!(off_floor(&table, "derma-render", render).is_empty());
    assert!(unlisted_uses(&table, "derma-render", render).is_empty());
    // Upward: off its floor (and unlisted).
    let up = format!("{render}derma-shading.workspace = true\n");
    assert_eq!(
        off_floor(&table, "derma-render", &up),
        ["derma-render (floor 2) depends on derma-shading (floor 3)"]
    );
    // Downward, so on its floor, but not in its row.
    let down = "[dependencies]\nderma-core.workspace = true\nderma-render.workspace = true\nderma-head.workspace = true\n";
    assert!(off_floor(&table, "derma-shading", down).is_empty());
    assert_eq!(
        unlisted_uses(&table, "derma-shading", down),
        ["derma-shading depends on derma-head, which its row does not list"]
    );
    // Listed but not declared.
    let fewer = "[dependencies]\nderma-core.workspace = true\n";
    assert_eq!(
        unlisted_uses(&table, "derma-render", fewer),
        ["derma-render's row lists derma-head, which its Cargo.toml does not declare"]
    );
    assert_eq!(
        off_floor(&table, "derma-eyes", fewer),
        ["derma-eyes is missing from ARCHITECTURE.md's crate table"]
    );
    assert!(off_floor(&table, "derma-test-support", fewer).is_empty());
}

/// Whether `src` defines its own free-text `Invalid(String)` error variant (tests left out).
fn own_invalid_variant(src: &str) -> bool {
    let squeezed: String = non_test_code(src).split_whitespace().collect();
    squeezed.contains("Invalid(String)")
}

/// One error vocabulary: no library defines its own free-text `Invalid(String)`; a value that
/// cannot be used is derma-core's `Invalid {what, expected, got}`, wrapped (ARCHITECTURE.md).
#[test]
fn libraries_wrap_the_one_invalid_value_error() {
    let mut found = Vec::new();
    for krate in libraries() {
        for (f, src) in sources(&krate.join("src")) {
            if own_invalid_variant(&src) {
                found.push(f);
            }
        }
    }
    assert_none(&found, "an own Invalid(String) error variant");
}

#[test]
fn the_invalid_finder_finds_a_free_text_variant() {
    let wrapped =
        "pub enum E {\n    #[error(transparent)]\n    Invalid(#[from] derma_core::Invalid),\n}\n";
    assert!(!own_invalid_variant(wrapped));
    let free = "pub enum E {\n    #[error(\"{0}\")]\n    Invalid( String ),\n}\n";
    assert!(own_invalid_variant(free));
}

/// Whether a crate root's code warns (or denies) on public items without docs.
fn documents_public_items(lib: &str) -> bool {
    let squeezed: String = strip_comments_and_strings(lib).split_whitespace().collect();
    ["warn", "deny", "forbid"]
        .iter()
        .any(|l| squeezed.contains(&format!("#![{l}(missing_docs")))
}

#[test]
fn every_library_documents_its_public_items() {
    let mut missing = Vec::new();
    for k in libraries() {
        // derma-py's modules are private: its API is Python's, documented in docs/python.md.
        if name_of(&k) == "derma-py" {
            continue;
        }
        let lib = std::fs::read_to_string(k.join("src/lib.rs")).unwrap();
        if !documents_public_items(&lib) {
            missing.push(name_of(&k));
        }
    }
    assert_none(
        &missing,
        "libraries without #![warn(missing_docs)] in lib.rs:",
    );
}

#[test]
fn the_docs_lint_finder_finds_a_crate_without_it() {
    assert!(documents_public_items("//! x\n\n#![warn(missing_docs)]\n"));
    assert!(documents_public_items(
        "#![deny(missing_docs, unsafe_code)]\n"
    ));
    assert!(!documents_public_items(
        "//! #![warn(missing_docs)]\n#![warn(unsafe_code)]\n"
    ));
}

/// The citations of `arch` that name nothing: a backticked `.rs` path that `exists` does not
/// find (from the root, or from `crates/`; a bare file name beside the path cited before it),
/// and a backticked test name (snake case, four words or more) no `fn` of `fns` has.
fn dangling_citations(
    arch: &str,
    exists: &dyn Fn(&str) -> bool,
    fns: &BTreeSet<String>,
) -> Vec<String> {
    // Code blocks out: backticks only.
    let mut text = String::new();
    let mut fenced = false;
    for line in arch.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced {
            text.push_str(line);
            text.push('\n');
        }
    }
    let mut found = Vec::new();
    let mut beside: Option<String> = None;
    for cited in text.split('`').skip(1).step_by(2) {
        if cited.contains([' ', '\n', '*']) || cited.contains("::") {
            continue;
        }
        if cited.contains('/') {
            let path = [cited.to_string(), format!("crates/{cited}")]
                .into_iter()
                .find(|p| exists(p));
            match path {
                // A file (a name with an extension) sets its directory, a directory itself.
                Some(p) if p.rsplit('/').next().is_some_and(|n| n.contains('.')) => {
                    beside = Path::new(&p)
                        .parent()
                        .map(|d| d.to_string_lossy().into_owned())
                }
                Some(p) => beside = Some(p.trim_end_matches('/').to_string()),
                None if cited.ends_with(".rs") => found.push(format!("`{cited}`: no such file")),
                None => {}
            }
        } else if cited.ends_with(".rs") {
            let path = beside.as_ref().map(|d| format!("{d}/{cited}"));
            if !path.as_ref().is_some_and(|p| exists(p)) {
                found.push(format!(
                    "`{cited}`: not in {}",
                    beside
                        .as_deref()
                        .unwrap_or("the directory of an earlier citation")
                ));
            }
        } else if cited.matches('_').count() >= 3
            && cited
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
            && !fns.contains(cited)
        {
            found.push(format!("`{cited}`: no such test"));
        }
    }
    found
}

/// The names of the functions `src` defines.
fn fn_names(src: &str) -> Vec<String> {
    functions(&strip_comments_and_strings(src))
        .into_iter()
        .map(|f| f.name)
        .collect()
}

#[test]
fn architecture_cites_files_and_tests_that_exist() {
    let root = workspace();
    let arch = std::fs::read_to_string(root.join("ARCHITECTURE.md")).unwrap();
    let fns: BTreeSet<String> = crates()
        .iter()
        .flat_map(|k| ["src", "tests", "benches", "examples"].map(|d| k.join(d)))
        .flat_map(|d| sources(&d))
        .flat_map(|(_, src)| fn_names(&src))
        .collect();
    let found = dangling_citations(&arch, &|p| root.join(p).exists(), &fns);
    assert_none(&found, "ARCHITECTURE.md cites what is not there:");
}

#[test]
fn the_citation_finder_finds_a_missing_file_and_test() {
    let arch = "\
Checked by `crates/derma/tests/tidy.rs` (`tidy.rs`, `crates_sit_on_their_floors`).
```
not a `citation.rs`
```
- bit-identical (`derma-skin/tests/pipeline.rs`, `derma/tests/cli.rs`, `render_cli.rs`,
  `gone_cli.rs`, `derma/tests/nothing.rs`, `the_gpu_stays_off_by_default`, `map::box_reduced`,
  `surface_specular`, `tests/robust_*.rs`).
";
    let files = [
        "crates/derma/tests/tidy.rs",
        "crates/derma-skin/tests/pipeline.rs",
        "crates/derma/tests/cli.rs",
        "crates/derma/tests/render_cli.rs",
    ];
    let fns: BTreeSet<String> = ["crates_sit_on_their_floors".to_string()].into();
    let found = dangling_citations(arch, &|p| files.contains(&p), &fns);
    assert_eq!(
        found,
        [
            "`gone_cli.rs`: not in crates/derma/tests",
            "`derma/tests/nothing.rs`: no such file",
            "`the_gpu_stays_off_by_default`: no such test",
        ]
    );
}

/// The test files of a crate with `autotests = false` (its `tests/*.rs` names in `files`) that
/// its `tests/suite.rs` (`suite`) does not declare as `mod name;`: Cargo builds the suite alone,
/// so such a file would never run.
fn undeclared_test_files(manifest: &str, suite: Option<&str>, files: &[String]) -> Vec<String> {
    let one_binary = table_lines(manifest, "package")
        .iter()
        .any(|t| t.split_whitespace().collect::<String>() == "autotests=false");
    if !one_binary {
        return Vec::new();
    }
    let Some(suite) = suite else {
        return vec!["tests/suite.rs: missing (the manifest says autotests = false)".into()];
    };
    let code: String = strip_comments_and_strings(suite)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    files
        .iter()
        .filter(|f| *f != "suite.rs")
        .filter(|f| !code.contains(&format!("mod {};", f.trim_end_matches(".rs"))))
        .map(|f| format!("tests/{f}: not declared in tests/suite.rs"))
        .collect()
}

#[test]
fn every_test_file_is_in_its_suite() {
    let mut found = Vec::new();
    for k in crates() {
        let tests = k.join("tests");
        let files: Vec<String> = std::fs::read_dir(&tests)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|f| f.ends_with(".rs"))
            .collect();
        let suite = std::fs::read_to_string(tests.join("suite.rs")).ok();
        for f in undeclared_test_files(&manifest_of(&k), suite.as_deref(), &files) {
            found.push(format!("{}: {f}", name_of(&k)));
        }
    }
    assert_none(&found, "test files that never run:");
}

#[test]
fn the_suite_finder_finds_a_file_that_never_runs() {
    let manifest =
        "[package]\nname = \"x\"\n# one binary\nautotests = false\n\n[[test]]\nname = \"suite\"\n";
    let suite = "//! mod gone;\n#[cfg(feature = \"gpu\")]\nmod gpu;\nmod pipeline;\n#[path = \"support/truth.rs\"]\nmod truth;\n";
    let files: Vec<String> = [
        "suite.rs",
        "gpu.rs",
        "pipeline.rs",
        "gone.rs",
        "robust_files.rs",
    ]
    .map(String::from)
    .to_vec();
    assert_eq!(
        undeclared_test_files(manifest, Some(suite), &files),
        [
            "tests/gone.rs: not declared in tests/suite.rs",
            "tests/robust_files.rs: not declared in tests/suite.rs"
        ]
    );
    assert_eq!(undeclared_test_files(manifest, None, &files).len(), 1);
    // Without the flag Cargo builds every file: nothing to declare.
    assert!(undeclared_test_files("[package]\nname = \"x\"\n", None, &files).is_empty());
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
    ("crates/derma-eyes/src/files.rs", "animate", 122),
    ("crates/derma-head/src/subdivision.rs", "catmull_clark", 123),
    ("crates/derma-optics/src/transport.rs", "trace", 162),
    ("crates/derma-photo/src/chromophores.rs", "invert_with", 157),
    ("crates/derma-photo/src/register.rs", "register", 129),
    ("crates/derma-photo/src/register.rs", "refine", 129),
    ("crates/derma-photo/src/resection.rs", "dlt", 128),
    ("crates/derma-photo/src/resection.rs", "refine", 132),
    ("crates/derma-photo/src/resection.rs", "resect", 138),
    ("crates/derma-photo/src/unwrap.rs", "unwrap", 164),
    (
        "crates/derma-shading/src/match_report.rs",
        "write_plots",
        174,
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
