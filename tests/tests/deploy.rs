//! `deploy/` cannot drift from the CLI (issue 6): every YAML file there (every document
//! of it) and every TOML file parses, and every couplet command line written there — a
//! container's `command`/`args` (Kubernetes) or `entrypoint`/`command` (compose) run on
//! the image's ENTRYPOINT, the Dockerfile's ENTRYPOINT + CMD and RUN lines, shell
//! scripts, systemd `Exec*=` lines, and the indented example lines of every file's
//! header comment and of `deploy/README.md`'s code blocks — is checked against the real
//! CLI: each subcommand on the way is run with `--help` (clap refuses an unknown one),
//! and every `--flag` must be listed by the `--help` of the subcommand it is given to,
//! with its value when the flag takes one. A failure names the file and line.
//!
//! Indexed Jobs that fan out a sweep (`--sweep --point`) must also have as many
//! completions as the case's sweep has points (`couplet validate NAME --sweep --count`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

fn deploy_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy");
    // Errors then name /…/deploy/k8s/serve.yaml rather than /…/tests/../deploy/….
    d.canonicalize().unwrap_or(d)
}

// ---------------------------------------------------------------------------------------
// YAML with line numbers: yaml-rust2's `Yaml` drops the marks, its event parser keeps them.

#[derive(Debug, Clone)]
enum Value {
    Scalar(String),
    Seq(Vec<Node>),
    Map(Vec<(String, Node)>),
}

#[derive(Debug, Clone)]
struct Node {
    /// 1-based line of the node's start.
    line: usize,
    value: Value,
}

impl Node {
    /// The value of `key`, also through merge keys (`<<: *anchor`, compose's `x-` blocks).
    fn get(&self, key: &str) -> Option<&Node> {
        let Value::Map(m) = &self.value else {
            return None;
        };
        m.iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v)
            .or_else(|| {
                let merged = m.iter().find(|(k, _)| k == "<<").map(|(_, v)| v)?;
                match &merged.value {
                    Value::Seq(maps) => maps.iter().find_map(|n| n.get(key)),
                    _ => merged.get(key),
                }
            })
    }
    fn scalar(&self) -> Option<&str> {
        match &self.value {
            Value::Scalar(s) => Some(s),
            _ => None,
        }
    }
    /// Every node of the tree, this one first.
    fn walk<'a>(&'a self, out: &mut Vec<&'a Node>) {
        out.push(self);
        match &self.value {
            Value::Seq(s) => s.iter().for_each(|n| n.walk(out)),
            Value::Map(m) => m.iter().for_each(|(_, n)| n.walk(out)),
            Value::Scalar(_) => {}
        }
    }
}

/// A collection being built: its line, its anchor id (0: none), its items.
enum Frame {
    Seq(usize, usize, Vec<Node>),
    Map(usize, usize, Vec<(String, Node)>, Option<String>),
}

#[derive(Default)]
struct Builder {
    stack: Vec<Frame>,
    docs: Vec<Node>,
    /// Anchored nodes by id, for the aliases that repeat them.
    anchors: HashMap<usize, Node>,
}

impl Builder {
    fn finish(&mut self, node: Node, anchor: usize) {
        if anchor > 0 {
            self.anchors.insert(anchor, node.clone());
        }
        match self.stack.last_mut() {
            Some(Frame::Seq(_, _, items)) => items.push(node),
            Some(Frame::Map(_, _, entries, key)) => match key.take() {
                Some(k) => entries.push((k, node)),
                // A complex (non-scalar) key is kept as empty: manifests use none.
                None => *key = Some(node.scalar().unwrap_or_default().to_owned()),
            },
            None => self.docs.push(node),
        }
    }
}

impl MarkedEventReceiver for Builder {
    fn on_event(&mut self, ev: Event, mark: Marker) {
        let line = mark.line();
        match ev {
            Event::Scalar(s, _, anchor, _) => self.finish(
                Node {
                    line,
                    value: Value::Scalar(s),
                },
                anchor,
            ),
            // The anchored node again (the parser has refused an unknown alias).
            Event::Alias(id) => {
                let node = self.anchors.get(&id).cloned().unwrap_or(Node {
                    line,
                    value: Value::Scalar(String::new()),
                });
                self.finish(node, 0);
            }
            Event::SequenceStart(anchor, _) => {
                self.stack.push(Frame::Seq(line, anchor, Vec::new()))
            }
            Event::MappingStart(anchor, _) => {
                self.stack.push(Frame::Map(line, anchor, Vec::new(), None))
            }
            Event::SequenceEnd | Event::MappingEnd => {
                let (node, anchor) = match self.stack.pop() {
                    Some(Frame::Seq(line, anchor, items)) => (
                        Node {
                            line,
                            value: Value::Seq(items),
                        },
                        anchor,
                    ),
                    Some(Frame::Map(line, anchor, entries, _)) => (
                        Node {
                            line,
                            value: Value::Map(entries),
                        },
                        anchor,
                    ),
                    None => return,
                };
                self.finish(node, anchor);
            }
            _ => {}
        }
    }
}

/// Every document of a YAML stream, or the parser's error (it carries line and column).
fn parse_yaml(text: &str) -> Result<Vec<Node>, String> {
    let mut b = Builder::default();
    Parser::new_from_str(text)
        .load(&mut b, true)
        .map_err(|e| e.to_string())?;
    Ok(b.docs)
}

// ---------------------------------------------------------------------------------------
// Shell words and where couplet is the program.

/// One couplet invocation found in a file: the arguments after the program.
#[derive(Debug, Clone, PartialEq)]
struct Found {
    file: PathBuf,
    line: usize,
    args: Vec<String>,
}

/// A token of a shell line: a word (quotes removed) or an operator.
#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Word(String),
    Op(String),
}

/// Splits one logical shell line into words and operators (`;`, `&&`, `|`, `(`, `$(`,
/// redirections …), with single and double quotes and backslash escapes; a `#` at the
/// start of a word ends the line. Expansions stay as written (`$SLURM_ARRAY_TASK_ID`):
/// only flags and subcommand names are checked.
fn shell_tokens(line: &str) -> Vec<Tok> {
    let mut out = Vec::new();
    let mut word = String::new();
    let mut in_word = false;
    let mut chars = line.chars().peekable();
    let flush = |word: &mut String, in_word: &mut bool, out: &mut Vec<Tok>| {
        if *in_word {
            out.push(Tok::Word(std::mem::take(word)));
            *in_word = false;
        }
    };
    while let Some(c) = chars.next() {
        match c {
            '\'' => {
                in_word = true;
                for c in chars.by_ref() {
                    if c == '\'' {
                        break;
                    }
                    word.push(c);
                }
            }
            '"' => {
                in_word = true;
                while let Some(c) = chars.next() {
                    match c {
                        '"' => break,
                        '\\' => {
                            if let Some(n) = chars.next() {
                                word.push(n);
                            }
                        }
                        c => word.push(c),
                    }
                }
            }
            '\\' => {
                in_word = true;
                if let Some(n) = chars.next() {
                    word.push(n);
                }
            }
            '#' if !in_word => break,
            '$' if chars.peek() == Some(&'(') => {
                chars.next();
                flush(&mut word, &mut in_word, &mut out);
                out.push(Tok::Op("$(".into()));
            }
            ';' | '|' | '&' | '(' | ')' | '<' | '>' => {
                flush(&mut word, &mut in_word, &mut out);
                let mut op = c.to_string();
                while let Some(&n) = chars.peek() {
                    if matches!(n, '|' | '&' | '>' | '<') && op.len() < 2 {
                        op.push(n);
                        chars.next();
                    } else {
                        break;
                    }
                }
                out.push(Tok::Op(op));
            }
            c if c.is_whitespace() => flush(&mut word, &mut in_word, &mut out),
            c => {
                in_word = true;
                word.push(c);
            }
        }
    }
    flush(&mut word, &mut in_word, &mut out);
    out
}

/// The program `couplet` by name or path (`couplet`, `/usr/local/bin/couplet`).
fn is_couplet(word: &str) -> bool {
    word.rsplit('/').next() == Some("couplet")
}

/// An image name that is this project's (`couplet`, `couplet:latest`, `reg/couplet:1`).
fn is_couplet_image(image: &str) -> bool {
    let name = image.rsplit('/').next().unwrap_or(image);
    name.split([':', '@']).next() == Some("couplet")
}

/// Words that run the next word as a command.
const PREFIXES: &[&str] = &[
    "exec", "srun", "time", "nice", "nohup", "sudo", "env", "then", "do", "else", "!",
];

/// The couplet argument lists of one shell line: where `couplet` is the program of a
/// simple command, and where `docker run … IMAGE ARGS` runs this project's image (whose
/// ENTRYPOINT, `image_entry`, ends in couplet).
fn couplet_in_shell(line: &str, image_entry: &[String]) -> Vec<Vec<String>> {
    let toks = shell_tokens(line);
    let mut found = Vec::new();
    let words_until_op = |from: usize| -> Vec<String> {
        toks[from..]
            .iter()
            .map_while(|t| match t {
                Tok::Word(w) => Some(w.clone()),
                Tok::Op(_) => None,
            })
            .collect()
    };
    let mut command_position = true;
    for (i, t) in toks.iter().enumerate() {
        match t {
            Tok::Op(_) => command_position = true,
            Tok::Word(w) => {
                if command_position && is_couplet(w) {
                    found.push(words_until_op(i + 1));
                } else if command_position
                    && matches!(w.as_str(), "docker" | "podman")
                    && matches!(toks.get(i + 1), Some(Tok::Word(r)) if r == "run")
                {
                    // Options are written `--opt=value` in deploy/'s examples, so the
                    // image is the first word after `run` that is not an option.
                    let rest = words_until_op(i + 2);
                    if let Some(k) = rest.iter().position(|w| !w.starts_with('-'))
                        && is_couplet_image(&rest[k])
                    {
                        let mut argv = image_entry.to_vec();
                        argv.extend_from_slice(&rest[k + 1..]);
                        found.extend(couplet_in_argv(&argv, image_entry));
                    }
                }
                let assignment = w
                    .split_once('=')
                    .is_some_and(|(n, _)| !n.is_empty() && !n.starts_with('-'));
                command_position =
                    command_position && (assignment || PREFIXES.contains(&w.as_str()));
            }
        }
    }
    found
}

/// The couplet argument lists of an exec-form command (`["tini", "--", "couplet", …]`,
/// a container's command + args): after the element that is couplet, or inside the
/// script of `sh -c SCRIPT`.
fn couplet_in_argv(argv: &[String], image_entry: &[String]) -> Vec<Vec<String>> {
    if let Some(k) = argv.iter().position(|a| is_couplet(a)) {
        return vec![argv[k + 1..].to_vec()];
    }
    let shell = argv
        .first()
        .is_some_and(|a| matches!(a.rsplit('/').next(), Some("sh" | "bash")));
    match argv.iter().position(|a| a == "-c") {
        Some(k) if shell => argv
            .get(k + 1)
            .map(|script| {
                logical_lines(script)
                    .iter()
                    .flat_map(|(_, l)| couplet_in_shell(l, image_entry))
                    .collect()
            })
            .unwrap_or_default(),
        _ => Vec::new(),
    }
}

/// Lines joined across trailing backslashes, each with the 1-based number of its first.
fn logical_lines(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut cur: Option<(usize, String)> = None;
    for (i, raw) in text.lines().enumerate() {
        let (start, mut acc) = cur.take().unwrap_or((i + 1, String::new()));
        match raw.trim_end().strip_suffix('\\') {
            Some(head) => {
                acc.push_str(head);
                acc.push(' ');
                cur = Some((start, acc));
            }
            None => {
                acc.push_str(raw);
                out.push((start, acc));
            }
        }
    }
    out.extend(cur);
    out
}

/// The example command lines of a file's comments: `#` then at least four spaces (the
/// indented blocks of every deploy/ header), continued across `\`.
fn comment_examples(text: &str) -> Vec<(usize, String)> {
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut continuing = false;
    for (i, raw) in text.lines().enumerate() {
        let body = raw.trim_start().strip_prefix('#');
        let example = body.filter(|b| b.starts_with("    ") || (continuing && !b.is_empty()));
        match example {
            Some(b) => {
                let b = b.trim();
                let (b, more) = match b.strip_suffix('\\') {
                    Some(h) => (h, true),
                    None => (b, false),
                };
                match out.last_mut() {
                    Some((_, acc)) if continuing => {
                        acc.push(' ');
                        acc.push_str(b);
                    }
                    _ => out.push((i + 1, b.to_owned())),
                }
                continuing = more;
            }
            None => continuing = false,
        }
    }
    out
}

/// The lines inside ``` fences of a markdown file.
fn markdown_code(text: &str) -> Vec<(usize, String)> {
    let mut inside = false;
    let mut code = String::new();
    let mut first = 0;
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        if l.trim_start().starts_with("```") {
            if inside {
                out.extend(
                    logical_lines(&code)
                        .into_iter()
                        .map(|(n, l)| (first + n, l)),
                );
                code.clear();
            }
            inside = !inside;
            first = i + 1;
        } else if inside {
            code.push_str(l);
            code.push('\n');
        }
    }
    out
}

// ---------------------------------------------------------------------------------------
// Where the command lines are, file by file.

/// The final stage's ENTRYPOINT and CMD (exec form) of a Dockerfile, with their lines.
#[derive(Debug, Default, Clone)]
struct Image {
    entrypoint: Vec<String>,
    cmd: Vec<String>,
    cmd_line: usize,
}

/// Dockerfile instructions (continuations joined, comment lines dropped as Docker does).
fn dockerfile_instructions(text: &str) -> Vec<(usize, String, String)> {
    let code: String = text
        .lines()
        .map(|l| {
            if l.trim_start().starts_with('#') {
                ""
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    logical_lines(&code)
        .into_iter()
        .filter_map(|(n, l)| {
            let l = l.trim();
            let (kw, rest) = l.split_once(char::is_whitespace)?;
            Some((n, kw.to_ascii_uppercase(), rest.trim().to_owned()))
        })
        .collect()
}

fn exec_form(file: &Path, line: usize, value: &str) -> Result<Vec<String>, String> {
    serde_json::from_str::<Vec<String>>(value).map_err(|e| {
        format!(
            "{}:{line}: `{value}` is not an exec-form JSON array of strings: {e}",
            file.display()
        )
    })
}

fn dockerfile(file: &Path, text: &str) -> Result<(Image, Vec<Found>), String> {
    let mut image = Image::default();
    let mut entry_line = 0;
    let mut found = Vec::new();
    for (n, kw, rest) in dockerfile_instructions(text) {
        match kw.as_str() {
            // Each stage starts afresh; what counts is the last (the runtime).
            "FROM" => image = Image::default(),
            "ENTRYPOINT" => {
                image.entrypoint = exec_form(file, n, &rest)?;
                entry_line = n;
            }
            "CMD" => {
                image.cmd = exec_form(file, n, &rest)?;
                image.cmd_line = n;
            }
            "RUN" => {
                // `RUN --mount=… cmd`: the flags are BuildKit's.
                let cmd = rest
                    .split_whitespace()
                    .skip_while(|w| w.starts_with("--"))
                    .collect::<Vec<_>>()
                    .join(" ");
                for args in couplet_in_shell(&cmd, &[]) {
                    found.push(Found {
                        file: file.to_owned(),
                        line: n,
                        args,
                    });
                }
            }
            _ => {}
        }
    }
    let mut argv = image.entrypoint.clone();
    argv.extend(image.cmd.iter().cloned());
    for args in couplet_in_argv(&argv, &[]) {
        found.push(Found {
            file: file.to_owned(),
            line: image.cmd_line.max(entry_line),
            args,
        });
    }
    Ok((image, found))
}

fn strings(file: &Path, node: &Node) -> Result<Vec<String>, String> {
    match &node.value {
        Value::Seq(items) => items
            .iter()
            .map(|n| {
                n.scalar().map(str::to_owned).ok_or_else(|| {
                    format!(
                        "{}:{}: a command line element must be a string",
                        file.display(),
                        n.line
                    )
                })
            })
            .collect(),
        // compose's string form is split like a shell does.
        Value::Scalar(s) => Ok(shell_tokens(s)
            .into_iter()
            .filter_map(|t| match t {
                Tok::Word(w) => Some(w),
                Tok::Op(_) => None,
            })
            .collect()),
        Value::Map(_) => Err(format!(
            "{}:{}: a command line must be a list or a string",
            file.display(),
            node.line
        )),
    }
}

/// The couplet command lines of the containers in one YAML document. Kubernetes
/// (`apiVersion`): `command` replaces the image's ENTRYPOINT and `args` its CMD; compose
/// (`services`): `entrypoint` and `command` do. A container without its own
/// entrypoint runs ours when its image is this project's (or compose builds it).
fn yaml_commands(file: &Path, doc: &Node, image: &Image) -> Result<Vec<Found>, String> {
    let kubernetes = doc.get("apiVersion").is_some();
    let mut all = Vec::new();
    if kubernetes {
        doc.walk(&mut all);
    } else if let Some(Value::Map(services)) = doc.get("services").map(|s| &s.value) {
        // compose runs only what `services` names (`x-…` blocks are templates).
        all.extend(services.iter().map(|(_, s)| s));
    }
    let mut found = Vec::new();
    for c in all {
        let ours = c
            .get("image")
            .and_then(Node::scalar)
            .is_some_and(is_couplet_image)
            || (!kubernetes && c.get("build").is_some());
        let (entry_key, args_key) = if kubernetes {
            ("command", "args")
        } else {
            ("entrypoint", "command")
        };
        let (entry, args) = (c.get(entry_key), c.get(args_key));
        if c.get("image").is_none() && c.get("build").is_none() && entry.is_none() {
            continue;
        }
        let mut argv = match entry {
            Some(e) => strings(file, e)?,
            None if ours => image.entrypoint.clone(),
            None => continue,
        };
        match args {
            Some(a) => argv.extend(strings(file, a)?),
            None if entry.is_none() => argv.extend(image.cmd.iter().cloned()),
            None => {}
        }
        let line = args.or(entry).map_or(c.line, |n| n.line);
        for a in couplet_in_argv(&argv, &image.entrypoint) {
            found.push(Found {
                file: file.to_owned(),
                line,
                args: a,
            });
        }
    }
    Ok(found)
}

/// systemd `Exec*=` lines (their `-@:+!` prefixes removed).
fn systemd_commands(file: &Path, text: &str) -> Vec<Found> {
    logical_lines(text)
        .into_iter()
        .filter_map(|(n, l)| {
            let (k, v) = l.trim().split_once('=')?;
            k.starts_with("Exec").then(|| {
                let v = v.trim_start_matches(['-', '@', ':', '+', '!']);
                couplet_in_shell(v, &[])
                    .into_iter()
                    .map(|args| Found {
                        file: file.to_owned(),
                        line: n,
                        args,
                    })
                    .collect::<Vec<_>>()
            })
        })
        .flatten()
        .collect()
}

fn shell_commands(file: &Path, lines: &[(usize, String)], image: &Image) -> Vec<Found> {
    lines
        .iter()
        .flat_map(|(n, l)| {
            couplet_in_shell(l, &image.entrypoint)
                .into_iter()
                .map(|args| Found {
                    file: file.to_owned(),
                    line: *n,
                    args,
                })
        })
        .collect()
}

fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_owned()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

fn ext(p: &Path) -> &str {
    p.extension().and_then(|e| e.to_str()).unwrap_or("")
}

/// Every file of `dir` parsed (YAML, TOML) and searched for couplet command lines.
/// What [`scan`] found in a folder.
#[derive(Debug)]
struct Scan {
    /// Every couplet command line.
    found: Vec<Found>,
    /// How many of them each file holds.
    per_file: HashMap<PathBuf, usize>,
    /// The Indexed Jobs: file, document.
    jobs: Vec<(PathBuf, Node)>,
}

fn scan(dir: &Path) -> Result<Scan, String> {
    let files = files_under(dir);
    let image = match files
        .iter()
        .find(|f| f.file_name().is_some_and(|n| n == "Dockerfile"))
    {
        Some(f) => dockerfile(f, &std::fs::read_to_string(f).map_err(|e| e.to_string())?)?.0,
        None => Image::default(),
    };
    let mut found = Vec::new();
    let mut per_file = HashMap::new();
    let mut jobs = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).map_err(|e| format!("{}: {e}", f.display()))?;
        let name = f.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let mut here = Vec::new();
        match ext(f) {
            "yaml" | "yml" => {
                let docs = parse_yaml(&text).map_err(|e| format!("{}: {e}", f.display()))?;
                for d in &docs {
                    here.extend(yaml_commands(f, d, &image)?);
                    let indexed = d.get("spec").and_then(|s| s.get("completionMode"));
                    if indexed.and_then(Node::scalar) == Some("Indexed") {
                        jobs.push((f.clone(), d.clone()));
                    }
                }
            }
            "toml" => {
                toml::from_str::<toml::Table>(&text)
                    .map_err(|e| format!("{}: {e}", f.display()))?;
            }
            "service" => here.extend(systemd_commands(f, &text)),
            "md" => here.extend(shell_commands(f, &markdown_code(&text), &image)),
            "sh" | "sbatch" => {
                let code: Vec<_> = logical_lines(&text)
                    .into_iter()
                    .filter(|(_, l)| !l.trim_start().starts_with('#'))
                    .collect();
                here.extend(shell_commands(f, &code, &image));
            }
            _ if name == "Dockerfile" => here.extend(dockerfile(f, &text)?.1),
            _ => {}
        }
        if ext(f) != "md" {
            here.extend(shell_commands(f, &comment_examples(&text), &image));
        }
        per_file.insert(f.clone(), here.len());
        found.extend(here);
    }
    Ok(Scan {
        found,
        per_file,
        jobs,
    })
}

// ---------------------------------------------------------------------------------------
// The CLI's own word on a command line.

#[derive(Debug, Clone)]
struct Opt {
    long: Option<String>,
    short: Option<char>,
    takes_value: bool,
}

#[derive(Debug, Clone)]
struct Help {
    subcommands: Vec<String>,
    options: Vec<Opt>,
}

/// `couplet-cli PATH… --help`, parsed: its subcommands and options (clap's layout).
fn help(path: &[String]) -> Result<Help, String> {
    type Cache = HashMap<Vec<String>, Result<Help, String>>;
    static CACHE: Mutex<Option<Cache>> = Mutex::new(None);
    let mut cache = CACHE.lock().unwrap_or_else(|p| p.into_inner());
    let cache = cache.get_or_insert_with(HashMap::new);
    if let Some(h) = cache.get(path) {
        return h.clone();
    }
    let out = Command::new(CLI)
        .args(path)
        .arg("--help")
        .output()
        .map_err(|e| format!("cannot run {CLI}: {e}"))?;
    let h = if out.status.success() {
        Ok(parse_help(&String::from_utf8_lossy(&out.stdout)))
    } else {
        Err(format!(
            "clap refuses `couplet {} --help`: {}",
            path.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    };
    cache.insert(path.to_vec(), h.clone());
    h
}

fn parse_help(text: &str) -> Help {
    let mut h = Help {
        subcommands: Vec::new(),
        options: Vec::new(),
    };
    let mut section = "";
    for l in text.lines() {
        if !l.starts_with(' ') {
            section = l.trim_end_matches(':');
            continue;
        }
        let indent = l.len() - l.trim_start().len();
        let words: Vec<&str> = l.split_whitespace().collect();
        match section {
            "Commands" if indent == 2 => h.subcommands.extend(words.first().map(|w| w.to_string())),
            // Option lines are indented 2 (with a short form) or 6; descriptions deeper.
            "Options" if indent <= 6 && l.trim_start().starts_with('-') => {
                let mut opt = Opt {
                    long: None,
                    short: None,
                    takes_value: false,
                };
                for (k, w) in words.iter().enumerate() {
                    let w = w.trim_end_matches(',');
                    if let Some(long) = w.strip_prefix("--") {
                        opt.long = Some(long.to_owned());
                        opt.takes_value = words.get(k + 1).is_some_and(|n| n.starts_with('<'));
                        break;
                    } else if let Some(s) = w.strip_prefix('-') {
                        opt.short = s.chars().next();
                        opt.takes_value = words.get(k + 1).is_some_and(|n| n.starts_with('<'));
                    }
                }
                h.options.push(opt);
            }
            _ => {}
        }
    }
    h
}

/// Checks `couplet ARGS…` against the CLI: the subcommands exist, every flag is one its
/// subcommand lists, a flag that takes a value has one.
fn check(args: &[String]) -> Result<(), String> {
    let mut path: Vec<String> = Vec::new();
    let mut h = help(&path)?;
    let mut i = 0;
    let here = |path: &[String]| {
        if path.is_empty() {
            "couplet".to_owned()
        } else {
            format!("couplet {}", path.join(" "))
        }
    };
    let listed = |h: &Help| {
        h.options
            .iter()
            .filter_map(|o| o.long.as_ref().map(|l| format!("--{l}")))
            .collect::<Vec<_>>()
            .join(", ")
    };
    while i < args.len() {
        let a = &args[i];
        if a == "--" {
            break;
        }
        if let Some(flag) = a.strip_prefix("--") {
            let (name, inline) = match flag.split_once('=') {
                Some((n, _)) => (n, true),
                None => (flag, false),
            };
            let opt = h
                .options
                .iter()
                .find(|o| o.long.as_deref() == Some(name))
                .ok_or_else(|| {
                    format!(
                        "`{}` has no flag --{name}; its --help lists: {}",
                        here(&path),
                        listed(&h)
                    )
                })?;
            if opt.takes_value && !inline {
                i += 1;
                if i >= args.len() {
                    return Err(format!("`{} --{name}` needs a value", here(&path)));
                }
            } else if !opt.takes_value && inline {
                return Err(format!("`{} --{name}` takes no value", here(&path)));
            }
        } else if a.len() > 1 && a.starts_with('-') {
            for c in a[1..].chars() {
                let opt = h
                    .options
                    .iter()
                    .find(|o| o.short == Some(c))
                    .ok_or_else(|| {
                        format!(
                            "`{}` has no flag -{c}; its --help lists: {}",
                            here(&path),
                            listed(&h)
                        )
                    })?;
                if opt.takes_value {
                    i += 1;
                    break;
                }
            }
        } else if !h.subcommands.is_empty() {
            if !h.subcommands.contains(a) {
                return Err(format!(
                    "`{}` has no subcommand `{a}`; it has: {}",
                    here(&path),
                    h.subcommands.join(", ")
                ));
            }
            path.push(a.clone());
            h = help(&path)?;
        }
        i += 1;
    }
    Ok(())
}

fn check_all(found: &[Found]) -> Vec<String> {
    found
        .iter()
        .filter_map(|f| {
            check(&f.args).err().map(|e| {
                format!(
                    "{}:{}: `couplet {}`: {e}",
                    f.file.display(),
                    f.line,
                    f.args.join(" ")
                )
            })
        })
        .collect()
}

// ---------------------------------------------------------------------------------------

/// Every manifest of deploy/ parses and every couplet command line in it is one the CLI
/// accepts; every file that exists to run couplet has at least one (so a line the
/// search missed cannot pass unchecked).
#[test]
fn deploy_matches_the_cli() {
    let dir = deploy_dir();
    let Scan {
        found, per_file, ..
    } = scan(&dir).unwrap_or_else(|e| panic!("{e}"));
    let errors = check_all(&found);
    assert!(
        errors.is_empty(),
        "deploy/ has drifted from the CLI:\n{}",
        errors.join("\n")
    );
    for (f, n) in &per_file {
        let runs_couplet = matches!(ext(f), "yaml" | "yml" | "service" | "sh" | "sbatch" | "md")
            || f.file_name().is_some_and(|n| n == "Dockerfile");
        assert!(
            !runs_couplet || *n > 0,
            "{}: no couplet command line found; the drift check would not see one",
            f.display()
        );
    }
    let subcommands = |s: &str| {
        found
            .iter()
            .filter(|f| f.args.first().map(String::as_str) == Some(s))
            .count()
    };
    assert!(subcommands("serve") >= 3, "{found:#?}");
    assert!(subcommands("validate") >= 4, "{found:#?}");
    // compose.split.yaml's two sides, one through a merge key (`<<: *couplet`).
    assert!(subcommands("fluid-server") >= 1, "{found:#?}");
    assert!(
        found
            .iter()
            .any(|f| f.args.first().is_some_and(|a| a == "run")
                && f.args.iter().any(|a| a == "--external")),
        "{found:#?}"
    );
}

/// An Indexed Job that fans out a sweep has one completion per point of the case's sweep.
#[test]
fn indexed_jobs_cover_the_sweep() {
    let dir = deploy_dir();
    let jobs = scan(&dir).unwrap_or_else(|e| panic!("{e}")).jobs;
    assert!(!jobs.is_empty(), "no Indexed Job in deploy/");
    let (image, _) = dockerfile(
        &dir.join("Dockerfile"),
        &std::fs::read_to_string(dir.join("Dockerfile")).unwrap(),
    )
    .unwrap();
    for (file, job) in jobs {
        let found = yaml_commands(&file, &job, &image).unwrap();
        let args = &found
            .iter()
            .find(|f| f.args.iter().any(|a| a == "--point"))
            .unwrap_or_else(|| panic!("{}: an Indexed Job without --sweep --point", file.display()))
            .args;
        assert_eq!(args[0], "validate");
        let count = Command::new(CLI)
            .args(["validate", &args[1], "--sweep", "--count"])
            .output()
            .unwrap();
        assert!(
            count.status.success(),
            "{}",
            String::from_utf8_lossy(&count.stderr)
        );
        let points: u64 = String::from_utf8_lossy(&count.stdout)
            .trim()
            .parse()
            .unwrap();
        let completions = job.get("spec").and_then(|s| s.get("completions")).unwrap();
        assert_eq!(
            completions.scalar().and_then(|c| c.parse::<u64>().ok()),
            Some(points),
            "{}:{}: completions must be the {} points of `{}`'s sweep",
            file.display(),
            completions.line,
            points,
            args[1]
        );
    }
}

/// The checker fails where the CLI would: an unknown flag, an unknown subcommand, a
/// flag's missing value, a flag given to the wrong subcommand; and accepts the lines
/// deploy/ writes, expansions included.
#[test]
fn checker_catches_drift() {
    let s = |v: &[&str]| v.iter().map(|a| a.to_string()).collect::<Vec<_>>();
    let e = check(&s(&["serve", "--lisen", "0.0.0.0:50051"])).unwrap_err();
    assert!(
        e.contains("`couplet serve` has no flag --lisen") && e.contains("--listen"),
        "{e}"
    );
    let e = check(&s(&["valdate", "settling-sphere"])).unwrap_err();
    assert!(
        e.contains("has no subcommand `valdate`") && e.contains("validate"),
        "{e}"
    );
    let e = check(&s(&["validate", "settling-sphere", "--sweep", "--point"])).unwrap_err();
    assert!(
        e.contains("`couplet validate --point` needs a value"),
        "{e}"
    );
    let e = check(&s(&["ctl", "create", "x.toml", "--server", "http://h:1"])).unwrap_err();
    assert!(
        e.contains("`couplet ctl create` has no flag --server"),
        "{e}"
    );
    let e = check(&s(&["validate", "x", "--quick=yes"])).unwrap_err();
    assert!(e.contains("--quick` takes no value"), "{e}");
    check(&s(&[
        "ctl",
        "--server",
        "http://h:1",
        "--token-file",
        "t",
        "create",
        "x.toml",
        "--start",
    ]))
    .unwrap();
    check(&s(&[
        "validate",
        "x",
        "--sweep",
        "--point",
        "$(JOB_COMPLETION_INDEX)",
        "--out=/sweep",
    ]))
    .unwrap();
    check(&s(&["--version"])).unwrap();
}

/// The search finds couplet where each kind of file puts it, and a drifted line is
/// reported with its file and line: a Kubernetes container's args (on the image's
/// ENTRYPOINT), compose's command, a shell script, systemd's ExecStart, a header example.
#[test]
fn drift_is_reported_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let w = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    };
    w(
        "Dockerfile",
        "FROM debian AS runtime\n# syntax check\nENTRYPOINT [\"tini\", \"--\", \"couplet\"]\nCMD [\"serve\", \"--listen\", \"0.0.0.0:1\"]\n",
    );
    w(
        "k8s/job.yaml",
        "# example:\n#     kubectl apply -f job.yaml\n---\napiVersion: batch/v1\nkind: Job\nspec:\n  template:\n    spec:\n      containers:\n        - name: a\n          image: reg/couplet:1\n          args: [validate, x, --sweep, --piont, \"3\"]\n        - name: b\n          image: busybox\n          args: [serve, --nonsense]\n",
    );
    w(
        "compose.yaml",
        "services:\n  s:\n    build: {context: ..}\n    command: serve --token-fil /x\n",
    );
    w(
        "run.sh",
        "#!/bin/sh\n# header:\n#     couplet valdate x \\\n#         --quick\nn=$(couplet validate x --sweep --count)\nexec /usr/local/bin/couplet validate x --swep \\\n  --point \"$K\"\necho \"couplet is not run here --at-all\"\n",
    );
    w(
        "u.service",
        "[Service]\nExecStart=-/usr/local/bin/couplet serve --data-dir %S/x --token-fle %d/t\n",
    );
    w("bad.yml", "a: [1, 2\nb: 3\n");
    let e = scan(dir.path()).unwrap_err();
    assert!(e.contains("bad.yml") && e.contains("line"), "{e}");
    std::fs::remove_file(dir.path().join("bad.yml")).unwrap();
    w("bad.toml", "x = \n");
    let e = scan(dir.path()).unwrap_err();
    assert!(e.contains("bad.toml"), "{e}");
    std::fs::remove_file(dir.path().join("bad.toml")).unwrap();

    let found = scan(dir.path()).unwrap().found;
    let errors = check_all(&found);
    let has = |needle: &str| errors.iter().any(|e| e.contains(needle));
    assert!(
        has("k8s/job.yaml:12: `couplet validate x --sweep --piont 3`"),
        "{errors:#?}"
    );
    assert!(
        has("compose.yaml:4: `couplet serve --token-fil /x`"),
        "{errors:#?}"
    );
    assert!(has("run.sh:3: `couplet valdate x --quick`"), "{errors:#?}");
    assert!(
        has("run.sh:6: `couplet validate x --swep --point $K`"),
        "{errors:#?}"
    );
    assert!(
        has("u.service:2: `couplet serve --data-dir %S/x --token-fle %d/t`"),
        "{errors:#?}"
    );
    assert_eq!(errors.len(), 5, "{errors:#?}");
    // Found but accepted: the Dockerfile's ENTRYPOINT + CMD and the $(…) in run.sh.
    assert_eq!(found.len(), 7, "{found:#?}");
}
