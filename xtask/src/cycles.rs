//! `cargo xtask cycles`: import cycles between the top-level modules of
//! each workspace crate.
//!
//! A text scan, not a compiler pass: a crate's top-level modules are the
//! first path components under its `src/` (`src/a.rs`, `src/a/mod.rs` and
//! `src/a/b.rs` all belong to `a`; `lib.rs` and `main.rs`, the crate root,
//! belong to none). Module `a` imports `b` when code in `a`'s files names a
//! `crate::b` path or lists `b` in a `crate::{..}` group, in code or in a
//! doc comment's link (a reader follows those too). Plain comments and
//! string literals are left out, and so is every item under `#[cfg(test)]`
//! (the `mod tests { .. }` blocks, and `#[cfg(test)] mod x;` files). What
//! the root re-exports (`crate::Error` for `error::Error`) and `super::`
//! paths are not followed.

use anyhow::{Context, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module `from` imports module `to`; `file:line` is the first place seen.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Edge {
    pub from: String,
    pub to: String,
    /// Relative to the crate's folder.
    pub file: PathBuf,
    pub line: usize,
}

/// Modules of one crate that import each other round (a strongly
/// connected component of more than one module), with the imports
/// between them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cycle {
    /// Sorted.
    pub modules: Vec<String>,
    /// The imports between `modules`, sorted by `from` then `to`.
    pub edges: Vec<Edge>,
}

/// The import cycles among the top-level modules of the crate in
/// `crate_dir` (which has a `src/`), in the order of their first module.
pub fn crate_cycles(crate_dir: &Path) -> Result<Vec<Cycle>> {
    let src = crate_dir.join("src");
    let mut files = vec![];
    rust_files(&src, &mut files)?;
    files.sort();
    let mut texts = BTreeMap::new();
    for f in &files {
        let text =
            std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
        texts.insert(f.clone(), text);
    }
    // Files declared by `#[cfg(test)] mod x;`, and everything under them.
    let mut test_only: Vec<PathBuf> = vec![];
    for (f, text) in &texts {
        let dir = child_dir(&src, f);
        for name in test_modules(&blank_comments_and_strings(text)) {
            test_only.push(dir.join(format!("{name}.rs")));
            test_only.push(dir.join(&name));
        }
    }
    let module_of = |f: &Path| -> Option<String> {
        let rel = f.strip_prefix(&src).ok()?;
        let mut parts = rel.components();
        let first = parts.next()?.as_os_str().to_string_lossy().into_owned();
        if parts.next().is_some() {
            // A folder: `a/...` is `a` (`bin/` holds crate roots of its own).
            return (first != "bin").then_some(first);
        }
        let stem = first.strip_suffix(".rs")?;
        (stem != "lib" && stem != "main").then(|| stem.to_string())
    };
    let modules: BTreeSet<String> = files.iter().filter_map(|f| module_of(f)).collect();
    let mut edges: BTreeMap<(String, String), Edge> = BTreeMap::new();
    for (f, text) in &texts {
        let code = blank_comments_and_strings(text);
        let whole_file_test = code
            .split_whitespace()
            .collect::<String>()
            .contains("#![cfg(test)]");
        if whole_file_test || test_only.iter().any(|t| f.starts_with(t)) {
            continue;
        }
        let Some(from) = module_of(f) else {
            continue;
        };
        let code = blank_test_items(&code);
        for (to, line) in crate_paths(&code) {
            if to != from && modules.contains(&to) {
                edges.entry((from.clone(), to.clone())).or_insert(Edge {
                    from: from.clone(),
                    to,
                    file: f.strip_prefix(crate_dir).unwrap_or(f).to_path_buf(),
                    line,
                });
            }
        }
    }
    let names: Vec<&String> = modules.iter().collect();
    let index: BTreeMap<&String, usize> = names.iter().enumerate().map(|(i, n)| (*n, i)).collect();
    let mut next = vec![vec![]; names.len()];
    for (from, to) in edges.keys() {
        next[index[from]].push(index[to]);
    }
    let mut cycles: Vec<Cycle> = strongly_connected(&next)
        .into_iter()
        .filter(|c| c.len() > 1)
        .map(|c| {
            let mut modules: Vec<String> = c.iter().map(|&i| names[i].clone()).collect();
            modules.sort();
            let edges = edges
                .values()
                .filter(|e| modules.contains(&e.from) && modules.contains(&e.to))
                .cloned()
                .collect();
            Cycle { modules, edges }
        })
        .collect();
    cycles.sort_by(|a, b| a.modules.cmp(&b.modules));
    Ok(cycles)
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    for entry in std::fs::read_dir(dir).with_context(|| format!("listing {}", dir.display()))? {
        let path = entry?.path();
        if path.is_dir() {
            rust_files(&path, out)?;
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    Ok(())
}

/// The folder that a file's `mod x;` children live in: its own folder for
/// `lib.rs`, `main.rs` and `mod.rs`, else a folder named after it.
fn child_dir(src: &Path, f: &Path) -> PathBuf {
    let parent = f.parent().unwrap_or(src).to_path_buf();
    let stem = f.file_stem().map(|s| s.to_string_lossy().into_owned());
    match stem.as_deref() {
        Some("mod") => parent,
        Some("lib" | "main") if parent == src => parent,
        Some(s) => parent.join(s),
        None => parent,
    }
}

fn is_ident(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

/// `text` with comments, string and character literals replaced by
/// spaces (newlines kept, so byte offsets and line numbers stay).
pub fn blank_comments_and_strings(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = b.to_vec();
    let blank = |out: &mut Vec<u8>, from: usize, to: usize| {
        for c in &mut out[from..to.min(b.len())] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
    };
    let mut i = 0;
    while i < b.len() {
        let prev_ident = i > 0 && is_ident(b[i - 1]);
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                let end = b[i..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(b.len(), |p| i + p);
                // Doc comments stay: their links (`[`crate::x`]`) send a
                // reader to `x` as surely as a `use` does.
                let doc = matches!(b.get(i + 2), Some(b'!'))
                    || (b.get(i + 2) == Some(&b'/') && b.get(i + 3) != Some(&b'/'));
                if !doc {
                    blank(&mut out, i, end);
                }
                i = end;
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                let (mut depth, mut j) = (0usize, i);
                while j < b.len() {
                    if b[j] == b'/' && b.get(j + 1) == Some(&b'*') {
                        depth += 1;
                        j += 2;
                    } else if b[j] == b'*' && b.get(j + 1) == Some(&b'/') {
                        depth -= 1;
                        j += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        j += 1;
                    }
                }
                blank(&mut out, i, j);
                i = j;
            }
            // Raw strings: r"..", r#".."#, br#".."#.
            b'r' if !prev_ident
                || (i > 0 && b[i - 1] == b'b' && (i < 2 || !is_ident(b[i - 2]))) =>
            {
                let hashes = b[i + 1..].iter().take_while(|&&c| c == b'#').count();
                if b.get(i + 1 + hashes) != Some(&b'"') {
                    i += 1;
                    continue;
                }
                let close: Vec<u8> = std::iter::once(b'"')
                    .chain(std::iter::repeat_n(b'#', hashes))
                    .collect();
                let start = i + 2 + hashes;
                let end = b[start..]
                    .windows(close.len())
                    .position(|w| w == close.as_slice())
                    .map_or(b.len(), |p| start + p + close.len());
                blank(&mut out, i + 1, end);
                i = end;
            }
            b'"' => {
                let mut j = i + 1;
                while j < b.len() && b[j] != b'"' {
                    j += if b[j] == b'\\' { 2 } else { 1 };
                }
                blank(&mut out, i, j + 1);
                i = j + 1;
            }
            b'\'' => {
                // A character literal ('x', '\n', '\u{..}', 'é') or a lifetime.
                let end = if b.get(i + 1) == Some(&b'\\') {
                    // After the escaped character: '\'' and '\\' end there.
                    let mut j = i + 3;
                    while j < b.len() && b[j] != b'\'' && b[j] != b'\n' {
                        j += 1;
                    }
                    Some(j)
                } else {
                    let len = text[i + 1..].chars().next().map_or(1, char::len_utf8);
                    (b.get(i + 1 + len) == Some(&b'\'')).then_some(i + 1 + len)
                };
                match end {
                    Some(j) => {
                        blank(&mut out, i, j + 1);
                        i = j + 1;
                    }
                    None => i += 1,
                }
            }
            _ => i += 1,
        }
    }
    String::from_utf8(out).expect("only ASCII bytes replaced, by spaces")
}

/// Byte offsets of each `#[cfg(test)]` attribute in blanked code.
fn cfg_test_attrs(code: &str) -> Vec<(usize, usize)> {
    let b = code.as_bytes();
    let mut out = vec![];
    let mut from = 0;
    while let Some(p) = code[from..].find("#[") {
        let start = from + p;
        let Some(len) = code[start..].find(']') else {
            break;
        };
        let inner: String = code[start + 2..start + len]
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect();
        if inner == "cfg(test)" && !(start > 0 && b[start - 1] == b'!') {
            out.push((start, start + len + 1));
        }
        from = start + len + 1;
    }
    out
}

/// Where the item starting at `from` ends: after its `;` or its block's
/// closing brace, whichever comes first (a `;` inside brackets, as in
/// `[u8; 3]`, ends nothing).
fn item_end(code: &str, from: usize) -> usize {
    let b = code.as_bytes();
    let (mut depth, mut brackets) = (0usize, 0usize);
    for (j, &c) in b.iter().enumerate().skip(from) {
        match c {
            b'(' | b'[' => brackets += 1,
            b')' | b']' => brackets = brackets.saturating_sub(1),
            b';' if depth == 0 && brackets == 0 => return j + 1,
            b'{' => depth += 1,
            b'}' => {
                if depth <= 1 {
                    return j + 1;
                }
                depth -= 1;
            }
            _ => {}
        }
    }
    b.len()
}

/// Blanked code with every `#[cfg(test)]` item blanked too.
fn blank_test_items(code: &str) -> String {
    let mut out = code.as_bytes().to_vec();
    let mut covered = 0;
    for (start, attr_end) in cfg_test_attrs(code) {
        if start < covered {
            continue;
        }
        let end = item_end(code, attr_end);
        for c in &mut out[start..end] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
        covered = end;
    }
    String::from_utf8(out).expect("only ASCII bytes replaced, by spaces")
}

/// Names `x` of `#[cfg(test)] mod x;` declarations in blanked code.
fn test_modules(code: &str) -> Vec<String> {
    cfg_test_attrs(code)
        .into_iter()
        .filter_map(|(_, attr_end)| {
            let item = &code[attr_end..item_end(code, attr_end)];
            let words: Vec<&str> = item
                .split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ';'))
                .filter(|w| !w.is_empty())
                .collect();
            // `[pub] mod x;` (other attributes between were split away).
            let m = words.iter().position(|w| *w == "mod")?;
            words.get(m + 1)?.strip_suffix(';').map(str::to_string)
        })
        .collect()
}

/// The first path component after each `crate::` in blanked code (each
/// member's of a `crate::{..}` group), with its line (1-based).
pub fn crate_paths(code: &str) -> Vec<(String, usize)> {
    let b = code.as_bytes();
    let line_of = |pos: usize| 1 + b[..pos].iter().filter(|&&c| c == b'\n').count();
    let skip_ws = |mut j: usize| {
        while j < b.len() && b[j].is_ascii_whitespace() {
            j += 1;
        }
        j
    };
    let ident_at = |j: usize| -> String {
        let end = b[j..]
            .iter()
            .position(|&c| !is_ident(c))
            .map_or(b.len(), |p| j + p);
        code[j..end].to_string()
    };
    let mut out = vec![];
    let mut from = 0;
    while let Some(p) = code[from..].find("crate") {
        let start = from + p;
        from = start + 5;
        if start > 0 && (is_ident(b[start - 1]) || b[start - 1] == b'$') {
            continue;
        }
        let j = skip_ws(start + 5);
        if !code[j..].starts_with("::") {
            continue;
        }
        let j = skip_ws(j + 2);
        if b.get(j) == Some(&b'{') {
            // Each member of the group: its first identifier at depth 1.
            let (mut depth, mut k, mut at_member) = (0usize, j, true);
            while k < b.len() {
                match b[k] {
                    b'{' => {
                        depth += 1;
                        at_member = depth == 1;
                    }
                    b'}' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    b',' if depth == 1 => at_member = true,
                    c if at_member && depth == 1 && is_ident(c) => {
                        out.push((ident_at(k), line_of(k)));
                        at_member = false;
                    }
                    _ => {}
                }
                k += 1;
            }
        } else {
            let name = ident_at(j);
            if !name.is_empty() {
                out.push((name, line_of(j)));
            }
        }
    }
    out.retain(|(n, _)| n != "self" && n != "super");
    out
}

/// Tarjan's strongly connected components of the graph `next[v]`.
fn strongly_connected(next: &[Vec<usize>]) -> Vec<Vec<usize>> {
    struct State<'a> {
        next: &'a [Vec<usize>],
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        counter: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(s: &mut State, v: usize) {
        s.index[v] = Some(s.counter);
        s.low[v] = s.counter;
        s.counter += 1;
        s.stack.push(v);
        s.on_stack[v] = true;
        for &w in &s.next[v] {
            match s.index[w] {
                None => {
                    visit(s, w);
                    s.low[v] = s.low[v].min(s.low[w]);
                }
                Some(iw) if s.on_stack[w] => s.low[v] = s.low[v].min(iw),
                Some(_) => {}
            }
        }
        if Some(s.low[v]) == s.index[v] {
            let mut comp = vec![];
            while let Some(w) = s.stack.pop() {
                s.on_stack[w] = false;
                comp.push(w);
                if w == v {
                    break;
                }
            }
            s.out.push(comp);
        }
    }
    let n = next.len();
    let mut s = State {
        next,
        index: vec![None; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: vec![],
        counter: 0,
        out: vec![],
    };
    for v in 0..n {
        if s.index[v].is_none() {
            visit(&mut s, v);
        }
    }
    s.out
}

/// The crates of the workspace at `root`: `crates/*` and `xtask`, each
/// with a `src/`.
pub fn workspace_crates(root: &Path) -> Result<Vec<PathBuf>> {
    let mut out = vec![];
    let crates = root.join("crates");
    for entry in
        std::fs::read_dir(&crates).with_context(|| format!("listing {}", crates.display()))?
    {
        let path = entry?.path();
        if path.join("src").is_dir() {
            out.push(path);
        }
    }
    if root.join("xtask/src").is_dir() {
        out.push(root.join("xtask"));
    }
    out.sort();
    Ok(out)
}

/// `cargo xtask cycles`: prints every cycle per crate; `Ok(false)` when
/// there is one.
pub fn run(root: &Path) -> Result<bool> {
    let crates = workspace_crates(root)?;
    let mut found = 0;
    let mut crates_with = 0;
    for dir in &crates {
        let cycles = crate_cycles(dir)?;
        if cycles.is_empty() {
            continue;
        }
        crates_with += 1;
        let shown = dir.strip_prefix(root).unwrap_or(dir).display().to_string();
        for c in &cycles {
            found += 1;
            println!(
                "{shown}: {} modules import each other round: {}",
                c.modules.len(),
                c.modules.join(", ")
            );
            for e in &c.edges {
                println!(
                    "  {} -> {}  ({}:{})",
                    e.from,
                    e.to,
                    e.file.display(),
                    e.line
                );
            }
        }
    }
    if found == 0 {
        println!("cycles: no module cycles in {} crates", crates.len());
        Ok(true)
    } else {
        println!(
            "cycles: {found} cycle(s) in {crates_with} of {} crates",
            crates.len()
        );
        Ok(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(root: &Path, files: &[(&str, &str)]) {
        for (path, text) in files {
            let p = root.join(path);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
    }

    /// The check CI runs: `cargo test` runs it with the other tests, so
    /// that CI does not build the xtask's dependencies a second time with
    /// its own feature set (about 2 minutes from a fresh clone on 2 cores)
    /// just for `cargo xtask cycles`.
    #[test]
    fn the_workspace_has_no_module_cycles() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let crates = workspace_crates(root).unwrap();
        // Every library crate and the xtask itself, not an empty listing.
        assert!(crates.len() >= 10, "{crates:?}");
        let found: Vec<String> = crates
            .iter()
            .flat_map(|dir| {
                let cycles = crate_cycles(dir).unwrap();
                cycles
                    .into_iter()
                    .map(move |c| format!("{}: {}", dir.display(), c.modules.join(" -> ")))
            })
            .collect();
        assert!(found.is_empty(), "module cycles: {found:#?}");
    }

    #[test]
    fn finds_a_cycle_and_only_it() {
        let tmp = tempfile::tempdir().unwrap();
        write(
            tmp.path(),
            &[
                (
                    "src/lib.rs",
                    "mod a;\nmod b;\nmod c;\nmod d;\npub use crate::a::A;\n",
                ),
                // a -> b through a group, b -> c through a path, c -> a in a
                // folder module's child file: a cycle of three.
                ("src/a.rs", "use crate::{b::B, d};\npub struct A;\n"),
                (
                    "src/b.rs",
                    "pub struct B;\nfn f() { let _ = crate::c::C; }\n",
                ),
                ("src/c/mod.rs", "mod inner;\npub struct C;\n"),
                ("src/c/inner.rs", "use crate::a::A;\n"),
                // d imports nothing: a's import of d is no cycle.
                ("src/d.rs", "pub struct D;\n"),
            ],
        );
        let cycles = crate_cycles(tmp.path()).unwrap();
        assert_eq!(cycles.len(), 1, "{cycles:?}");
        assert_eq!(cycles[0].modules, ["a", "b", "c"]);
        let edges: Vec<(&str, &str, usize)> = cycles[0]
            .edges
            .iter()
            .map(|e| (e.from.as_str(), e.to.as_str(), e.line))
            .collect();
        assert_eq!(edges, [("a", "b", 1), ("b", "c", 2), ("c", "a", 1)]);
        assert_eq!(cycles[0].edges[2].file, Path::new("src/c/inner.rs"));
    }

    #[test]
    fn tests_comments_and_strings_are_no_imports() {
        let tmp = tempfile::tempdir().unwrap();
        write(
            tmp.path(),
            &[
                ("src/main.rs", "mod a;\nmod b;\nfn main() { crate::a::f(); }\n"),
                ("src/a.rs", "pub fn f() { crate::b::g(); }\n"),
                // b names a only in a plain comment, a string, a test block,
                // a test-only file and a `$crate` macro path.
                (
                    "src/b.rs",
                    "// see crate::a\n\
                     pub fn g() { let _ = \"crate::a\"; let _ = r#\"crate::{a}\"#; let _c = '{'; }\n\
                     /* crate::a */\n\
                     macro_rules! m { () => { $crate::a::f() } }\n\
                     #[cfg(test)]\nmod tests {\n    use crate::a::f;\n    fn t() { if true { f() } }\n}\n\
                     #[cfg(test)]\nmod more;\n",
                ),
                ("src/b/more.rs", "use crate::a;\n"),
            ],
        );
        assert_eq!(crate_cycles(tmp.path()).unwrap(), vec![]);
        // The same crate with a real import back is a cycle.
        write(
            tmp.path(),
            &[("src/b/other.rs", "use crate::{self as x, a};\n")],
        );
        let cycles = crate_cycles(tmp.path()).unwrap();
        assert_eq!(cycles.len(), 1);
        assert_eq!(cycles[0].modules, ["a", "b"]);
    }

    #[test]
    fn a_doc_link_is_a_reference_a_plain_comment_is_not() {
        let code = blank_comments_and_strings(
            "//! Used by [`crate::a`].\n/// See [`crate::b::f`].\n// crate::c\n//// crate::d\nfn f() {}\n",
        );
        assert_eq!(
            crate_paths(&code),
            [("a".to_string(), 1), ("b".to_string(), 2)]
        );
    }

    #[test]
    fn group_members_and_lines() {
        let code = blank_comments_and_strings(
            "use crate::{\n    a::{x, y},\n    b,\n};\nfn f<'a>(s: &'a str) { crate :: c::z(); }\npub(crate) fn g() {}\n",
        );
        assert_eq!(
            crate_paths(&code),
            [
                ("a".to_string(), 2),
                ("b".to_string(), 3),
                ("c".to_string(), 5)
            ]
        );
    }
}
