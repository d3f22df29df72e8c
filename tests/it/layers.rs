//! Layers point one way (../shared/DESIGN.md), read by a parser: every source file under
//! `src/` is parsed with `syn`, every path it names that leads into the crate (`use` trees of
//! any shape, `crate::`/`super::`/`self::` chains, paths through a child module or an alias a
//! `use` made) is resolved to the module it reaches, and each arrow is checked against the
//! diagram. A path that points back up fails here, naming the file and the line.
//!
//! ```text
//! main.rs (CLI) ──► app (viewer) ──► stage ──► systems/<kind> ──► forces ──► scene ──► error, rng
//!       └──────► bench ──────────────┘   │            │
//!                                        └────────────┴──────────► gpu (the leaf)
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

/// A module path inside the crate, as segments (`["systems", "wisps", "march"]`).
type ModPath = Vec<String>;

/// One path a file names that leads into the crate.
#[derive(Debug, Clone)]
struct Arrow {
    /// The file, relative to the crate root.
    file: String,
    line: usize,
    /// Where the naming code sits (its module).
    from: ModPath,
    /// The crate path it resolves to (module and item segments).
    to: ModPath,
    /// Named from code under `#[cfg(test)]` (a leaf user: it imports anything).
    test: bool,
}

/// The `.rs` files under `dir`, recursively, sorted.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module a file under `src/` defines (`src/stage/mod.rs` → `stage`; `src/main.rs` →
/// `main`, the binary, which reaches the library as `kami::`).
fn module_of(rel: &Path) -> ModPath {
    let mut segs: ModPath = rel
        .iter()
        .map(|s| s.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if segs.last().is_some_and(|s| s == "mod" || s == "lib") {
        segs.pop();
    }
    segs
}

/// Walks one file's syntax tree, resolving every crate path it names.
struct Walker<'a> {
    file: String,
    /// The binary (`main.rs` and its modules) names the library as `kami::`.
    binary: bool,
    /// Every module the crate has (from the file tree plus inline `mod` blocks seen).
    modules: &'a BTreeSet<ModPath>,
    /// The module scopes entered (file module, then inline `mod` blocks).
    scope: Vec<ModPath>,
    /// Names a `use` bound in each scope, to what crate path.
    aliases: Vec<BTreeMap<String, ModPath>>,
    out: Vec<Arrow>,
}

impl Walker<'_> {
    fn here(&self) -> &ModPath {
        self.scope.last().unwrap()
    }

    /// Resolves a path's leading segments to a crate path, or `None` for another crate's
    /// path, a local name, or a primitive.
    fn resolve(&self, segs: &[String]) -> Option<ModPath> {
        let first = segs.first()?;
        let here = self.here().clone();
        let (mut base, rest) = match first.as_str() {
            "crate" if !self.binary => (ModPath::new(), &segs[1..]),
            "kami" if self.binary => (ModPath::new(), &segs[1..]),
            "crate" => (vec!["main".to_string()], &segs[1..]),
            "self" => (here, &segs[1..]),
            "super" => {
                let mut at = here;
                let mut i = 0;
                while segs.get(i).is_some_and(|s| s == "super") {
                    at.pop();
                    i += 1;
                }
                (at, &segs[i..])
            }
            _ => {
                // A child module of this scope, or a name a `use` bound.
                let mut child = here.clone();
                child.push(first.clone());
                if self.modules.contains(&child) {
                    (child, &segs[1..])
                } else if let Some(p) = self.aliases.iter().rev().find_map(|a| a.get(first)) {
                    (p.clone(), &segs[1..])
                } else {
                    return None;
                }
            }
        };
        base.extend(rest.iter().cloned());
        Some(base)
    }

    fn push(&mut self, to: ModPath, line: usize) {
        let from = self.here().clone();
        self.out.push(Arrow {
            file: self.file.clone(),
            line,
            from,
            to,
            test: false,
        });
    }

    /// Records every leaf of a `use` tree and binds its names in the current scope.
    fn use_tree(&mut self, prefix: &mut Vec<String>, tree: &syn::UseTree) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.use_tree(prefix, &p.tree);
                prefix.pop();
            }
            syn::UseTree::Name(n) => {
                let name = n.ident.to_string();
                self.use_leaf(
                    prefix,
                    &name,
                    (name != "self").then(|| name.clone()),
                    n.ident.span(),
                );
            }
            syn::UseTree::Rename(r) => {
                self.use_leaf(
                    prefix,
                    &r.ident.to_string(),
                    Some(r.rename.to_string()),
                    r.ident.span(),
                );
            }
            syn::UseTree::Glob(g) => {
                if let Some(to) = self.resolve(prefix) {
                    self.push(to, g.star_token.span.start().line);
                }
            }
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.use_tree(prefix, t);
                }
            }
        }
    }

    fn use_leaf(
        &mut self,
        prefix: &[String],
        name: &str,
        bind: Option<String>,
        span: proc_macro2::Span,
    ) {
        let mut segs = prefix.to_vec();
        if name != "self" {
            segs.push(name.to_string());
        }
        if let Some(to) = self.resolve(&segs) {
            self.push(to.clone(), span.start().line);
            let bind = bind.or_else(|| prefix.last().cloned());
            if let Some(b) = bind {
                self.aliases.last_mut().unwrap().insert(b, to);
            }
        }
    }
}

impl<'ast> Visit<'ast> for Walker<'_> {
    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        if m.content.is_none() {
            return;
        }
        let mut inner = self.here().clone();
        inner.push(m.ident.to_string());
        self.scope.push(inner);
        self.aliases.push(BTreeMap::new());
        // `use` items bind for the whole module, wherever they sit in it: read them first.
        for item in &m.content.as_ref().unwrap().1 {
            if let syn::Item::Use(u) = item {
                self.use_tree(&mut Vec::new(), &u.tree);
            }
        }
        for item in &m.content.as_ref().unwrap().1 {
            if !matches!(item, syn::Item::Use(_)) {
                self.visit_item(item);
            }
        }
        self.aliases.pop();
        self.scope.pop();
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        // Uses inside function bodies: bind for the rest of the file (close enough for names).
        self.use_tree(&mut Vec::new(), &u.tree);
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        let segs: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
        if segs.len() > 1 || p.leading_colon.is_none() {
            if let Some(to) = self.resolve(&segs) {
                if segs.len() > 1 {
                    let line = p.segments[0].ident.span().start().line;
                    self.push(to, line);
                }
            }
        }
        syn::visit::visit_path(self, p);
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        // Paths inside macro calls (`format!`, `matches!`, `assert!`) are tokens, not syntax:
        // parse them as expressions where they are, so `crate::x::y` there is seen too. A
        // body that is not a list of expressions (`vec![x; n]`, `wgsl!(world; ..)`, a
        // pattern with a guard) is scanned as tokens for `a::b` paths instead.
        if let Ok(args) = m.parse_body_with(
            syn::punctuated::Punctuated::<syn::Expr, syn::Token![,]>::parse_terminated,
        ) {
            for e in &args {
                self.visit_expr(e);
            }
        } else {
            self.scan_tokens(m.tokens.clone());
        }
        syn::visit::visit_macro(self, m);
    }
}

impl Walker<'_> {
    /// Every `a::b::…` run of identifiers in `tokens` (recursively into groups), resolved as
    /// a path.
    fn scan_tokens(&mut self, tokens: proc_macro2::TokenStream) {
        use proc_macro2::TokenTree;
        let trees: Vec<TokenTree> = tokens.into_iter().collect();
        let mut i = 0;
        while i < trees.len() {
            match &trees[i] {
                TokenTree::Group(g) => {
                    self.scan_tokens(g.stream());
                    i += 1;
                }
                TokenTree::Ident(first) => {
                    let mut segs = vec![first.to_string()];
                    let line = first.span().start().line;
                    let mut j = i + 1;
                    // `::` is two `:` puncts, then an identifier.
                    while let (
                        Some(TokenTree::Punct(a)),
                        Some(TokenTree::Punct(b)),
                        Some(TokenTree::Ident(n)),
                    ) = (trees.get(j), trees.get(j + 1), trees.get(j + 2))
                    {
                        if a.as_char() != ':' || b.as_char() != ':' {
                            break;
                        }
                        segs.push(n.to_string());
                        j += 3;
                    }
                    if segs.len() > 1 {
                        if let Some(to) = self.resolve(&segs) {
                            self.push(to, line);
                        }
                    }
                    i = j;
                }
                _ => i += 1,
            }
        }
    }
}

/// The arrows of one file's `items` (module `module`): its `use` items first, since they
/// bind for the whole file wherever they sit, then everything else.
fn walk(
    file: String,
    binary: bool,
    modules: &BTreeSet<ModPath>,
    module: ModPath,
    items: &[syn::Item],
) -> Vec<Arrow> {
    let mut w = Walker {
        file,
        binary,
        modules,
        scope: vec![module],
        aliases: vec![BTreeMap::new()],
        out: Vec::new(),
    };
    for item in items {
        if let syn::Item::Use(u) = item {
            w.use_tree(&mut Vec::new(), &u.tree);
        }
    }
    for item in items {
        if !matches!(item, syn::Item::Use(_)) {
            w.visit_item(item);
        }
    }
    w.out
}

/// Every arrow in `src/`, and every module the crate has.
fn arrows() -> (Vec<Arrow>, BTreeSet<ModPath>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut modules: BTreeSet<ModPath> = files
        .iter()
        .map(|f| module_of(f.strip_prefix(&src).unwrap()))
        .collect();
    let parsed: Vec<(PathBuf, syn::File)> = files
        .iter()
        .map(|f| {
            let text = std::fs::read_to_string(f).unwrap();
            let ast = syn::parse_file(&text)
                .unwrap_or_else(|e| panic!("{}: does not parse: {e}", f.display()));
            (f.clone(), ast)
        })
        .collect();
    // Inline `mod x { … }` blocks are modules too (tests, small helpers); those under
    // `#[cfg(test)]` are tests.
    struct Inline<'m>(
        &'m mut BTreeSet<ModPath>,
        &'m mut BTreeSet<ModPath>,
        ModPath,
    );
    impl<'ast> Visit<'ast> for Inline<'_> {
        fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
            if m.content.is_some() {
                self.2.push(m.ident.to_string());
                self.0.insert(self.2.clone());
                let cfg_test = m.attrs.iter().any(|a| {
                    a.path().is_ident("cfg")
                        && a.parse_args::<syn::Ident>().is_ok_and(|i| i == "test")
                });
                if cfg_test {
                    self.1.insert(self.2.clone());
                }
                syn::visit::visit_item_mod(self, m);
                self.2.pop();
            }
        }
    }
    let mut tests = BTreeSet::new();
    for (f, ast) in &parsed {
        let m = module_of(f.strip_prefix(&src).unwrap());
        Inline(&mut modules, &mut tests, m).visit_file(ast);
    }
    // The binary's modules: `main` and what `main.rs` declares (`cli`, `anim`, `output`).
    let mut binary_mods: BTreeSet<String> = ["main".to_string()].into();
    for (f, ast) in &parsed {
        if f.ends_with("src/main.rs") {
            for item in &ast.items {
                if let syn::Item::Mod(m) = item {
                    binary_mods.insert(m.ident.to_string());
                }
            }
        }
    }
    let mut out = Vec::new();
    for (f, ast) in &parsed {
        let rel = f.strip_prefix(&src).unwrap();
        let module = module_of(rel);
        let file = f.strip_prefix(root).unwrap().display().to_string();
        let binary = module.first().is_some_and(|m| binary_mods.contains(m));
        out.extend(walk(file, binary, &modules, module, &ast.items));
    }
    for a in &mut out {
        a.test = tests.iter().any(|t| a.from.starts_with(t));
    }
    // The crate root's re-exports (`kami::Scene`, `crate::Result`) lead to their modules.
    let root_names: BTreeMap<String, ModPath> = out
        .iter()
        .filter(|a| a.file == "src/lib.rs" && a.from.is_empty())
        .filter_map(|a| Some((a.to.last()?.clone(), a.to.clone())))
        .collect();
    for a in &mut out {
        let top = a.to.first().cloned().unwrap_or_default();
        if !modules.contains(&vec![top.clone()]) {
            if let Some(p) = root_names.get(&top) {
                a.to = p.iter().chain(&a.to[1..]).cloned().collect();
            }
        }
    }
    (out, modules)
}

/// The kinds: the folders under `src/systems/`.
fn kinds() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/systems");
    let mut k: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .map(|p| p.file_name().unwrap().to_string_lossy().to_string())
        .collect();
    k.sort();
    k
}

/// The layer a module belongs to: its top module, with `systems/<kind>` a layer of its own
/// (`kind`), the rest of `systems` the shared one (`systems`), and the binary `main`.
fn layer(m: &ModPath, kinds: &[String]) -> String {
    match m.first().map(String::as_str) {
        None => "lib".into(),
        Some("systems") if m.get(1).is_some_and(|k| kinds.contains(k)) => "kind".into(),
        Some("cli" | "anim" | "output") => "main".into(),
        Some(top) => top.into(),
    }
}

/// What each layer may name (besides itself), from the diagram in ../shared/DESIGN.md.
/// Modules the diagram leaves out sit where their imports put them: `formats` (strand files)
/// beside `scene`, `shaders` (the registry the kinds feed) above `gpu`, `fuzz` (the harness
/// over every reader) beside `bench`; the binary's own modules (`cli`, `anim`, `output`)
/// are the CLI's layer.
fn allowed(layer: &str) -> &'static [&'static str] {
    match layer {
        "gpu" => &["error", "rng"],
        "shaders" => &["error", "gpu"],
        "scene" | "formats" => &["error", "rng", "scene", "formats"],
        "forces" => &["error", "rng", "scene", "formats"],
        "kind" | "systems" => &[
            "error", "rng", "scene", "formats", "forces", "gpu", "shaders", "systems", "kind",
        ],
        "stage" => &[
            "error", "rng", "scene", "formats", "forces", "gpu", "shaders", "systems",
        ],
        "app" => &[
            "error", "rng", "scene", "formats", "forces", "gpu", "shaders", "systems", "stage",
        ],
        "bench" | "fuzz" => &[
            "error", "rng", "scene", "formats", "forces", "gpu", "shaders", "systems", "kind",
            "stage", "bench", "fuzz",
        ],
        "main" | "lib" => &[
            "error", "rng", "scene", "formats", "forces", "gpu", "shaders", "systems", "stage",
            "bench", "fuzz", "app", "main",
        ],
        // error, rng: the leaves.
        _ => &[],
    }
}

/// Code outside a kind's folder that may still name the kind: (file or folder prefix, kind or
/// `*`, why). Adding a kind touches its folder, the `KINDS` line and its bench file; every
/// other entry here is a study that needs one kind's insides, and says which.
const NAMES_A_KIND: &[(&str, &str, &str)] = &[
    (
        "src/systems/mod.rs",
        "*",
        "the `KINDS` registry: the one list of every kind and its fields of the scene file",
    ),
    ("src/bench/anjyo", "anjyo", "the kind's own bench file"),
    ("src/bench/fur.rs", "fur", "the kind's own bench file"),
    ("src/bench/strips", "strips", "the kind's own bench files"),
    ("src/bench/wisps", "wisps", "the kind's own bench files"),
    (
        "src/bench/capture.rs",
        "strips",
        "the EFF fitted to capture is the strips kind's (Kazama et al.), its study reads the fit",
    ),
    (
        "src/bench/guides.rs",
        "anjyo",
        "guides and followers are the Anjyo kind's; the study times its passes one by one",
    ),
    (
        "src/bench/lod.rs",
        "anjyo",
        "strand LOD measures the Anjyo kind's strands (the only kind drawn as thin strands)",
    ),
    (
        "src/bench/raster.rs",
        "anjyo",
        "the raster study times the Anjyo kind's compute rasteriser binned and walked per strand",
    ),
    (
        "src/bench/scale.rs",
        "anjyo",
        "strands at scale grooms the Anjyo kind up to a million strands",
    ),
    (
        "src/bench/splat.rs",
        "anjyo",
        "the splat study draws the Anjyo kind's strands both ways",
    ),
    (
        "src/bench/look/mitsuba.rs",
        "fur",
        "the look study compares kinds against a reference; fur's mesh setup is built directly",
    ),
];

#[test]
fn the_parser_sees_what_text_matching_missed() {
    // The walker itself, on code the old line matcher passed: a multi-line `use` group, a
    // `super::super::` chain, an inline path in a macro and a path through an alias.
    let src = r#"
        use crate::{
            stage::Stage,
            app,
        };
        fn f() {
            let _ = super::super::stage::x();
            assert!(crate::bench::ok());
            let _ = vec![crate::stage::Clock::new(); 3];
            app::run();
        }
    "#;
    let ast = syn::parse_file(src).unwrap();
    let modules: BTreeSet<ModPath> = [
        vec!["systems".to_string()],
        vec!["systems".into(), "wisps".into()],
        vec!["systems".into(), "wisps".into(), "march".into()],
    ]
    .into();
    let here = vec!["systems".into(), "wisps".into(), "march".into()];
    let arrows = walk("x.rs".into(), false, &modules, here, &ast.items);
    let to: BTreeSet<String> = arrows.iter().map(|a| a.to.join("::")).collect();
    for want in [
        "stage::Stage",
        "app",
        "systems::stage::x",
        "bench::ok",
        "stage::Clock::new",
        "app::run",
    ] {
        assert!(to.contains(want), "{want} not seen; saw {to:?}");
    }
}

/// Every arrow of the diagram, over the whole crate: systems name neither the viewer nor
/// the stage, forces no system, the scene no solver, force or GPU, `gpu` nothing of ours
/// above it (not even the shader registry), and the stage, the viewer and the shared
/// systems code no kind (the kinds are reached through `KINDS` and `HairSystem`).
#[test]
fn layers_point_one_way() {
    let (arrows, _) = arrows();
    let kinds = kinds();
    assert!(
        arrows.len() > 500,
        "the walker saw only {} crate paths: it has stopped reading the sources",
        arrows.len()
    );
    let mut bad = BTreeSet::new();
    for a in &arrows {
        let (from, to) = (layer(&a.from, &kinds), layer(&a.to, &kinds));
        if from != to && !allowed(&from).contains(&to.as_str()) {
            bad.insert(format!(
                "{}:{}: {from} names {to} ({})",
                a.file,
                a.line,
                a.to.join("::")
            ));
        }
        // A kind is named only from inside its own folder (or an allowed place).
        if to == "kind" {
            let k = &a.to[1];
            let inside = a.from.first().is_some_and(|s| s == "systems") && a.from.get(1) == Some(k);
            let excused = NAMES_A_KIND
                .iter()
                .any(|(f, kk, _)| a.file.starts_with(f) && (*kk == "*" || kk == k));
            if !inside && !excused {
                bad.insert(format!(
                    "{}:{}: names the kind `{k}` from outside src/systems/{k}/ ({})",
                    a.file,
                    a.line,
                    a.to.join("::")
                ));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{} arrows point the wrong way:\n{}",
        bad.len(),
        bad.into_iter().collect::<Vec<_>>().join("\n")
    );
}

/// The parts of `systems` an import cycle would join: each kind's folder as one part (its
/// files may name each other), every other file of `systems` a part of its own; `None` for
/// a module outside `systems`.
fn systems_part(m: &ModPath, kinds: &[String]) -> Option<String> {
    if m.first().map(String::as_str) != Some("systems") {
        return None;
    }
    Some(match m.get(1) {
        None => "systems (mod.rs)".into(),
        Some(k) if kinds.contains(k) => format!("systems::{k}/"),
        Some(f) => format!("systems::{f}"),
    })
}

/// The strongly connected groups of more than one node of `graph` (Tarjan), sorted.
fn cycles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'g> {
        graph: &'g BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'g str, usize>,
        low: BTreeMap<&'g str, usize>,
        stack: Vec<&'g str>,
        on: BTreeSet<&'g str>,
        out: Vec<Vec<String>>,
    }
    impl<'g> T<'g> {
        fn visit(&mut self, v: &'g str) {
            let i = self.index.len();
            self.index.insert(v, i);
            self.low.insert(v, i);
            self.stack.push(v);
            self.on.insert(v);
            for w in self.graph.get(v).into_iter().flatten() {
                let w = w.as_str();
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let lw = self.low[w];
                    let lv = self.low.get_mut(v).unwrap();
                    *lv = (*lv).min(lw);
                } else if self.on.contains(w) {
                    let iw = self.index[w];
                    let lv = self.low.get_mut(v).unwrap();
                    *lv = (*lv).min(iw);
                }
            }
            if self.low[v] == self.index[v] {
                let mut group = Vec::new();
                loop {
                    let w = self.stack.pop().unwrap();
                    self.on.remove(w);
                    group.push(w.to_string());
                    if w == v {
                        break;
                    }
                }
                if group.len() > 1 {
                    group.sort();
                    self.out.push(group);
                }
            }
        }
    }
    let mut t = T {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !t.index.contains_key(v.as_str()) {
            t.visit(v);
        }
    }
    t.out.sort();
    t.out
}

/// The imports inside `systems` form no cycle (issue 35): the kinds name the scene
/// (`systems::scene`) and the contract (`systems::kind`, `systems::system`, `systems::ui`),
/// which name no kind; only the registry (`systems/mod.rs`, with `KINDS`) names the kinds,
/// and nothing inside `systems` names it. Code under `#[cfg(test)]` is a
/// leaf user and is left out. A cycle fails here with every part it joins and one import
/// along each of its arrows.
#[test]
fn systems_import_no_cycle() {
    let (arrows, modules) = arrows();
    let kinds = kinds();
    // The module an arrow reaches: the longest prefix of its path that is a module.
    let module = |p: &ModPath| -> ModPath {
        (0..=p.len())
            .rev()
            .map(|n| p[..n].to_vec())
            .find(|m| modules.contains(m))
            .unwrap_or_default()
    };
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut why: BTreeMap<(String, String), String> = BTreeMap::new();
    for a in arrows.iter().filter(|a| !a.test) {
        let (Some(from), Some(to)) = (
            systems_part(&a.from, &kinds),
            systems_part(&module(&a.to), &kinds),
        ) else {
            continue;
        };
        if from != to {
            graph.entry(from.clone()).or_default().insert(to.clone());
            why.entry((from, to))
                .or_insert_with(|| format!("{}:{} ({})", a.file, a.line, a.to.join("::")));
        }
    }
    assert!(
        graph.keys().filter(|k| k.ends_with('/')).count() >= 4,
        "the kinds' imports were not seen: {:?}",
        graph.keys()
    );
    let found = cycles(&graph);
    let report: Vec<String> = found
        .iter()
        .map(|c| {
            let arrows: Vec<&String> = why
                .iter()
                .filter(|((f, t), _)| c.contains(f) && c.contains(t))
                .map(|(_, w)| w)
                .collect();
            format!(
                "cycle through {c:?}, by:\n  {}",
                arrows
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join("\n  ")
            )
        })
        .collect();
    assert!(report.is_empty(), "{}", report.join("\n"));
}

#[test]
fn the_cycle_finder_finds_cycles() {
    let g = |edges: &[(&str, &str)]| {
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in edges {
            g.entry(a.to_string()).or_default().insert(b.to_string());
        }
        g
    };
    assert!(cycles(&g(&[("a", "b"), ("b", "c"), ("a", "c")])).is_empty());
    assert_eq!(
        cycles(&g(&[
            ("a", "b"),
            ("b", "c"),
            ("c", "a"),
            ("c", "d"),
            ("d", "e"),
            ("e", "d")
        ])),
        vec![vec!["a", "b", "c"], vec!["d", "e"]]
    );
}

/// The longest a function outside tests may be, in lines: past this it is several steps that
/// want names (issue 35: small commands, small functions).
const MAX_FN_LINES: usize = 150;

/// No function or method outside tests (`#[cfg(test)]` modules, `#[test]` functions) is
/// longer than `MAX_FN_LINES`, read from the parsed sources.
#[test]
fn functions_stay_short() {
    struct Long<'a>(&'a str, Vec<String>);
    fn is_test(attrs: &[syn::Attribute]) -> bool {
        attrs.iter().any(|a| {
            a.path().is_ident("test")
                || (a.path().is_ident("cfg")
                    && a.parse_args::<syn::Ident>().is_ok_and(|i| i == "test"))
        })
    }
    impl Long<'_> {
        fn check(&mut self, name: &syn::Ident, block: &syn::Block) {
            use syn::spanned::Spanned;
            let (a, b) = (block.span().start().line, block.span().end().line);
            if b - a + 1 > MAX_FN_LINES {
                self.1
                    .push(format!("{}:{a}: fn {name} is {} lines", self.0, b - a + 1));
            }
        }
    }
    impl<'ast> Visit<'ast> for Long<'_> {
        fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
            if !is_test(&m.attrs) {
                syn::visit::visit_item_mod(self, m);
            }
        }
        fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
            if !is_test(&f.attrs) {
                self.check(&f.sig.ident, &f.block);
                syn::visit::visit_item_fn(self, f);
            }
        }
        fn visit_trait_item_fn(&mut self, f: &'ast syn::TraitItemFn) {
            if let Some(block) = f.default.as_ref().filter(|_| !is_test(&f.attrs)) {
                self.check(&f.sig.ident, block);
            }
            syn::visit::visit_trait_item_fn(self, f);
        }
        fn visit_impl_item_fn(&mut self, f: &'ast syn::ImplItemFn) {
            if !is_test(&f.attrs) {
                self.check(&f.sig.ident, &f.block);
                syn::visit::visit_impl_item_fn(self, f);
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    sources(&root.join("src"), &mut files);
    let mut long = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let ast = syn::parse_file(&text).unwrap();
        let rel = f.strip_prefix(root).unwrap().display().to_string();
        let mut v = Long(&rel, Vec::new());
        v.visit_file(&ast);
        long.extend(v.1);
    }
    assert!(
        long.is_empty(),
        "functions longer than {MAX_FN_LINES} lines:\n{}",
        long.join("\n")
    );
}

/// No binding number is typed by hand outside `src/gpu/bind.rs`: every layout and bind group
/// in the crate and its tests is built there, from typed slots in order (issue 35 item 2).
/// Read from the parsed sources: a `BindGroupEntry`/`BindGroupLayoutEntry` literal or a
/// `create_bind_group(_layout)` call anywhere else fails, naming the file and line.
#[test]
fn bindings_are_declared_in_order_by_type() {
    struct Hand<'a>(&'a str, Vec<String>);
    impl<'ast> Visit<'ast> for Hand<'_> {
        fn visit_expr_struct(&mut self, e: &'ast syn::ExprStruct) {
            let last = e.path.segments.last().map(|s| s.ident.to_string());
            if let Some(n) = last.filter(|n| n == "BindGroupEntry" || n == "BindGroupLayoutEntry") {
                let line = e.path.segments[0].ident.span().start().line;
                self.1
                    .push(format!("{}:{line}: a {n} written by hand", self.0));
            }
            syn::visit::visit_expr_struct(self, e);
        }
        fn visit_expr_method_call(&mut self, c: &'ast syn::ExprMethodCall) {
            let m = c.method.to_string();
            if m == "create_bind_group" || m == "create_bind_group_layout" {
                let line = c.method.span().start().line;
                self.1
                    .push(format!("{}:{line}: {m} called directly", self.0));
            }
            syn::visit::visit_expr_method_call(self, c);
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    sources(&root.join("src"), &mut files);
    sources(&root.join("tests"), &mut files);
    sources(&root.join("examples"), &mut files);
    let mut hand = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(root).unwrap().display().to_string();
        if rel == "src/gpu/bind.rs" {
            continue;
        }
        let ast = syn::parse_file(&std::fs::read_to_string(f).unwrap()).unwrap();
        let mut v = Hand(&rel, Vec::new());
        v.visit_file(&ast);
        hand.extend(v.1);
    }
    assert!(
        hand.is_empty(),
        "bindings numbered by hand:\n{}",
        hand.join("\n")
    );
}
