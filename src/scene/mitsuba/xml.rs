//! Reads a Mitsuba XML file into a plain element tree: `<include>` spliced in, `<default>` values
//! collected and every `$name` substituted, each element keeping its file and line for error messages.
use crate::scene::SceneError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Deepest `<include>` nesting accepted (an include cycle is refused long before).
const MAX_INCLUDE_DEPTH: usize = 16;
/// Most `<include>` elements read in all (files that include each other twice over grow exponentially).
const MAX_INCLUDES: usize = 1000;
/// Deepest element nesting accepted (real scenes nest a handful of levels; this bounds the recursion).
const MAX_ELEMENT_DEPTH: usize = 64;

#[derive(Clone, Debug)]
pub struct Node {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Node>,
    /// The file the element was read from, and its line there.
    pub file: PathBuf,
    pub line: u32,
}

impl Node {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }

    /// `<tag type="…" name="…">` as the user wrote it, for messages.
    pub fn describe(&self) -> String {
        let mut s = format!("<{}", self.tag);
        for key in ["type", "name", "id"] {
            if let Some(v) = self.attr(key) {
                s += &format!(" {key}=\"{v}\"");
            }
        }
        s + ">"
    }

    /// An error about this element: file, line, element, message.
    pub fn error(&self, msg: impl std::fmt::Display) -> SceneError {
        SceneError::Parse {
            file: self.file.display().to_string(),
            msg: format!("line {}: {}: {msg}", self.line, self.describe()),
        }
    }

    /// The folder the element's file is in (relative file names resolve against it).
    pub fn dir(&self) -> PathBuf {
        self.file.parent().map(Path::to_path_buf).unwrap_or_default()
    }
}

/// Reads `path`, which must hold a `<scene>`; returns it with includes spliced in and `$name`
/// references replaced by `<default>` values (the first definition wins, as in Mitsuba). What the
/// reader leaves out as Mitsuba does, it says in `warnings`.
pub fn read_scene(path: &Path, warnings: &mut Vec<String>) -> Result<Node, SceneError> {
    let mut root = read_file(path, 0, &mut 0, warnings)?;
    if root.attr("version").is_some_and(|v| v.starts_with("0.")) {
        snake_case_names(&mut root);
    }
    let mut defaults = HashMap::new();
    collect_defaults(&root, &mut defaults)?;
    substitute(&mut root, &defaults)?;
    Ok(root)
}

/// Most XML nodes a file may hold (elements, text, comments; entities expanded): real scenes hold
/// thousands, and this bounds what a hostile file's entities can ask for.
const MAX_XML_NODES: u32 = 1 << 24;

/// A file's XML, a `<!DOCTYPE>` allowed (Mitsuba's reader takes one, and internal entities as macros),
/// entity expansion bounded by the parser's own check against exponential entities and by
/// `MAX_XML_NODES`.
fn parse_xml(text: &str) -> Result<roxmltree::Document<'_>, roxmltree::Error> {
    let options = roxmltree::ParsingOptions { allow_dtd: true, nodes_limit: MAX_XML_NODES, ..Default::default() };
    roxmltree::Document::parse_with_options(text, options)
}

/// An XML declaration after blank lines or spaces (a file a script wrote with a newline first), which
/// XML forbids and Mitsuba's reader takes: blanked to spaces, every length and line kept (the reader
/// takes UTF-8 whatever the declaration says).
fn lenient_declaration(text: &str) -> std::borrow::Cow<'_, str> {
    use std::borrow::Cow;
    let body = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lead = body.len() - body.trim_start().len();
    if lead == 0 || !body[lead..].starts_with("<?xml") {
        return Cow::Borrowed(text);
    }
    let Some(end) = body[lead..].find("?>") else { return Cow::Borrowed(text) };
    let at = text.len() - body.len() + lead;
    let blank: String = text[at..at + end + 2].chars().map(|c| if c == '\n' { c } else { ' ' }).collect();
    Cow::Owned(format!("{}{blank}{}", &text[..at], &text[at + end + 2..]))
}

/// Text before the first element (after the declaration, between comments), which XML forbids and
/// Mitsuba's reader ignores: blanked to spaces, every line and column kept, with the line it starts on.
/// None where there is none.
fn lenient_prologue(text: &str) -> Option<(String, usize)> {
    let mut blank = Vec::new();
    let mut at = text.len() - text.strip_prefix('\u{feff}').unwrap_or(text).len();
    loop {
        at += text[at..].len() - text[at..].trim_start().len();
        let rest = &text[at..];
        let close = [("<?", "?>"), ("<!--", "-->")].iter().find(|(open, _)| rest.starts_with(open));
        match close {
            Some((open, close)) => match rest[open.len()..].find(close) {
                Some(e) => at += open.len() + e + close.len(),
                None => break,
            },
            None if rest.is_empty() || rest.starts_with('<') => break,
            None => {
                let end = rest.find('<').unwrap_or(rest.len());
                blank.push(at..at + end);
                at += end;
            }
        }
    }
    let line = text[..blank.first()?.start].matches('\n').count() + 1;
    let mut out = String::with_capacity(text.len());
    let mut from = 0;
    for r in blank {
        out.push_str(&text[from..r.start]);
        out.extend(text[r.clone()].chars().map(|c| if c == '\n' { c } else { ' ' }));
        from = r.end;
    }
    out.push_str(&text[from..]);
    Some((out, line))
}

/// Markup as Mitsuba's reader (pugixml) takes it where strict XML refuses it, rewritten so that the
/// strict parser reads it, lines kept (and, in comments, columns):
/// - comments with `--` inside or ending `--->` (decorative `<!-- ---- lights ---- -->`, dashes in
///   prose): each dash next to another dash (or to the closing `-->`) becomes a space. A comment ends
///   at its first `-->`, as in both; an unterminated one stays for the parser to report.
/// - attribute values with a bare `&` that starts no reference (a file name `R&D.png`), an entity XML
///   does not define (`&nbsp;`, without a `<!DOCTYPE>` to define it) or a `<`: read as written, so
///   escaped (`&amp;`, `&lt;`).
///
/// CDATA, declarations, processing instructions and text outside tags are left alone.
fn lenient_markup(text: &str) -> std::borrow::Cow<'_, str> {
    use std::borrow::Cow;
    let has_dtd = text.contains("<!DOCTYPE");
    // Whether `rest` (just after an `&`) is a reference the parser takes: a character reference, one of
    // XML's five entities, or (with a DTD to define it) any well-formed name.
    let reference = |rest: &str| {
        let Some(end) = rest.find(';').filter(|&e| e > 0 && e <= 32) else { return false };
        let name = &rest[..end];
        if let Some(num) = name.strip_prefix('#') {
            return match num.strip_prefix('x') {
                Some(hex) => !hex.is_empty() && hex.chars().all(|c| c.is_ascii_hexdigit()),
                None => !num.is_empty() && num.chars().all(|c| c.is_ascii_digit()),
            };
        }
        let well_formed = name.chars().enumerate().all(|(i, c)| {
            c.is_alphabetic() || c == '_' || c == ':' || (i > 0 && (c.is_alphanumeric() || matches!(c, '-' | '.')))
        });
        well_formed && (has_dtd || ["amp", "lt", "gt", "quot", "apos"].contains(&name))
    };
    let mut out = String::with_capacity(text.len());
    let mut changed = false;
    let mut rest = text;
    while let Some(at) = rest.find('<') {
        out.push_str(&rest[..at]);
        rest = &rest[at..];
        // A comment: its dash pairs blanked. CDATA, declarations and processing instructions: copied whole.
        if let Some(n) = rest.strip_prefix("<!--").and_then(|r| r.find("-->")) {
            let body = &rest[4..4 + n];
            let bytes = body.as_bytes();
            out.push_str("<!--");
            for (k, c) in body.char_indices() {
                let paired = c == '-' && (k + 1 == bytes.len() || bytes[k + 1] == b'-');
                changed |= paired;
                out.push(if paired { ' ' } else { c });
            }
            out.push_str("-->");
            rest = &rest[4 + n + 3..];
            continue;
        }
        // (An unterminated comment is copied whole, for the parser to report.)
        let skip = [("<!--", "-->"), ("<![CDATA[", "]]>"), ("<?", "?>"), ("<!", ">")]
            .iter()
            .find(|(open, _)| rest.starts_with(open))
            .map(|(open, close)| rest[open.len()..].find(close).map_or(rest.len(), |e| open.len() + e + close.len()));
        if let Some(n) = skip {
            out.push_str(&rest[..n]);
            rest = &rest[n..];
            continue;
        }
        // A tag: copied up to its `>`, its quoted values escaped where needed.
        out.push('<');
        rest = &rest[1..];
        let mut quote = None;
        let mut end = rest.len();
        for (i, c) in rest.char_indices() {
            match (quote, c) {
                (None, '>') => {
                    out.push('>');
                    end = i + 1;
                    break;
                }
                (None, '"' | '\'') => quote = Some(c),
                (Some(q), _) if c == q => quote = None,
                (Some(_), '&') if !reference(&rest[i + 1..]) => {
                    out.push_str("&amp;");
                    changed = true;
                    continue;
                }
                (Some(_), '<') => {
                    out.push_str("&lt;");
                    changed = true;
                    continue;
                }
                _ => {}
            }
            out.push(c);
        }
        rest = &rest[end.min(rest.len())..];
    }
    out.push_str(rest);
    if changed {
        Cow::Owned(out)
    } else {
        Cow::Borrowed(text)
    }
}

/// Where the first top-level element of `text` ends, when `err` (the parse of the whole) is about
/// well-formed content after it: another element, text, comments. Mitsuba's reader (pugixml) takes a
/// document of several top-level elements, and Mitsuba reads the first; strict XML refuses them. None
/// when the error lies elsewhere, or what follows is not well-formed (which Mitsuba refuses too).
fn first_element_end(text: &str, err: &roxmltree::Error) -> Option<usize> {
    let roxmltree::Error::UnknownToken(pos) = err else { return None };
    // The error's row and column (in characters), as a byte offset.
    let line_start = match pos.row {
        0 => return None,
        1 => 0,
        row => text.match_indices('\n').nth(row as usize - 2)?.0 + 1,
    };
    let col = pos.col.checked_sub(1)? as usize;
    let at = line_start + text[line_start..].char_indices().nth(col).map_or(text.len() - line_start, |(i, _)| i);
    let (head, tail) = text.split_at(at);
    parse_xml(head).ok()?;
    parse_xml(&format!("<after>{tail}</after>")).ok()?;
    Some(at)
}

fn read_file(path: &Path, depth: usize, includes: &mut usize, warnings: &mut Vec<String>) -> Result<Node, SceneError> {
    let shown = path.display().to_string();
    let text = crate::scene::read_text(path).map_err(|msg| SceneError::Io { file: shown.clone(), msg })?;
    let declared = lenient_declaration(&text);
    let prologue = lenient_prologue(&declared);
    if let Some((_, line)) = &prologue {
        warnings.push(format!("{shown}: line {line}: text before the first element is ignored, as Mitsuba ignores it"));
    }
    let text = lenient_markup(prologue.as_ref().map_or(&*declared, |(t, _)| t.as_str()));
    let parse_error = |e: roxmltree::Error| SceneError::Parse { file: shown.clone(), msg: format!("XML: {e}") };
    let doc = match parse_xml(&text) {
        Ok(doc) => doc,
        Err(e) => {
            let end = first_element_end(&text, &e).ok_or_else(|| parse_error(e))?;
            let line = text[..end].matches('\n').count() + 1;
            warnings.push(format!(
                "{shown}: line {line}: what follows the first top-level element is ignored, as Mitsuba ignores it"
            ));
            parse_xml(&text[..end]).map_err(parse_error)?
        }
    };
    let root = doc.root_element();
    let mut node = convert(&doc, root, path, 0)?;
    if node.tag != "scene" {
        return Err(node.error("the top element must be <scene version=\"3.x\">"));
    }
    match node.attr("version") {
        Some(v) if ["3.", "2.", "0.6", "0.5"].iter().any(|p| v.starts_with(p)) || v == "3" => {}
        Some(v) => return Err(node.error(format!("version {v} is not read (3.x, 2.x, 0.6 and 0.5 are)"))),
        None => return Err(node.error("missing the `version` attribute (e.g. version=\"3.0.0\")")),
    }
    let mut children = Vec::new();
    for child in std::mem::take(&mut node.children) {
        if child.tag != "include" {
            children.push(child);
            continue;
        }
        if depth >= MAX_INCLUDE_DEPTH {
            return Err(child.error(format!("includes nested deeper than {MAX_INCLUDE_DEPTH} (a cycle?)")));
        }
        *includes += 1;
        if *includes > MAX_INCLUDES {
            return Err(child.error(format!("more than {MAX_INCLUDES} includes in all")));
        }
        let name = child.attr("filename").ok_or_else(|| child.error("needs a `filename` attribute"))?;
        let inner = read_file(&child.dir().join(name), depth + 1, includes, warnings)
            .map_err(|e| child.error(format!("while including {name}: {e}")))?;
        children.extend(inner.children);
    }
    node.children = children;
    Ok(node)
}

fn convert(doc: &roxmltree::Document, n: roxmltree::Node, file: &Path, depth: usize) -> Result<Node, SceneError> {
    let line = doc.text_pos_at(n.range().start).row;
    if depth > MAX_ELEMENT_DEPTH {
        let msg = format!("line {line}: elements nested deeper than {MAX_ELEMENT_DEPTH} levels");
        return Err(SceneError::Parse { file: file.display().to_string(), msg });
    }
    Ok(Node {
        tag: n.tag_name().name().to_string(),
        attrs: n.attributes().map(|a| (a.name().to_string(), a.value().to_string())).collect(),
        children: n
            .children()
            .filter(|c| c.is_element())
            .map(|c| convert(doc, c, file, depth + 1))
            .collect::<Result<_, _>>()?,
        file: file.to_path_buf(),
        line,
    })
}

/// Mitsuba 0.5/0.6 wrote parameter names in camelCase (`toWorld`, `intIOR`); 3.x in snake_case.
fn snake_case_names(node: &mut Node) {
    for (k, v) in &mut node.attrs {
        if k == "name" {
            let mut out = String::new();
            let mut prev_lower = false;
            for c in v.chars() {
                if c.is_ascii_uppercase() && prev_lower {
                    out.push('_');
                }
                prev_lower = c.is_ascii_lowercase() || c.is_ascii_digit();
                out.push(c.to_ascii_lowercase());
            }
            *v = out;
        }
    }
    node.children.iter_mut().for_each(snake_case_names);
}

fn collect_defaults(scene: &Node, out: &mut HashMap<String, String>) -> Result<(), SceneError> {
    for d in scene.children.iter().filter(|c| c.tag == "default") {
        let (Some(name), Some(value)) = (d.attr("name"), d.attr("value")) else {
            return Err(d.error("needs `name` and `value` attributes"));
        };
        out.entry(name.to_string()).or_insert_with(|| value.to_string());
    }
    Ok(())
}

fn substitute(node: &mut Node, defaults: &HashMap<String, String>) -> Result<(), SceneError> {
    if node.tag != "default" {
        for i in 0..node.attrs.len() {
            let v = &node.attrs[i].1;
            if !v.contains('$') {
                continue;
            }
            let replaced = replace_refs(v, defaults).map_err(|name| {
                node.error(format!("`${name}` has no <default name=\"{name}\" value=\"…\"/> in the scene"))
            })?;
            node.attrs[i].1 = replaced;
        }
    }
    node.children.iter_mut().try_for_each(|c| substitute(c, defaults))
}

/// Replaces every `$name` (letters, digits, `_`) in `v`; Err(name) for one with no default.
fn replace_refs(v: &str, defaults: &HashMap<String, String>) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = v;
    while let Some(i) = rest.find('$') {
        out += &rest[..i];
        let after = &rest[i + 1..];
        let len = after.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(after.len());
        let name = &after[..len];
        out += defaults.get(name).ok_or_else(|| name.to_string())?;
        rest = &after[len..];
    }
    Ok(out + rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dollar_references_are_replaced_and_unknown_ones_named() {
        let d: HashMap<String, String> = [("spp".to_string(), "64".to_string())].into();
        assert_eq!(replace_refs("$spp", &d).unwrap(), "64");
        assert_eq!(replace_refs("a $spp, b", &d).unwrap(), "a 64, b");
        assert_eq!(replace_refs("$res_x", &d).unwrap_err(), "res_x");
    }

    /// Comments Mitsuba reads and strict XML does not (`--` inside, `--->` at the end) parse, each with
    /// its text's length and lines kept; other dashes, CDATA and a well-formed file are left alone.
    #[test]
    fn comments_with_dashes_are_read_as_mitsuba_reads_them() {
        let text = "<scene version=\"3.0.0\">\n<!-- ---- lights ---- -->\n<!-- a -- b --->\n<!---->\n\
                    <!-- a - b -->\n<x v=\"--\"><![CDATA[ <!-- -- --> ]]></x>\n</scene>";
        assert!(roxmltree::Document::parse(text).is_err(), "strict XML refuses it");
        let read = lenient_markup(text);
        assert_eq!((read.len(), read.lines().count()), (text.len(), text.lines().count()));
        let doc = roxmltree::Document::parse(&read).unwrap();
        let x = doc.descendants().find(|n| n.has_tag_name("x")).unwrap();
        assert_eq!((x.attribute("v"), x.text()), (Some("--"), Some(" <!-- -- --> ")));
        assert!(read.contains("<!-- a - b -->") && read.contains("<!---->"), "{read}");
        let plain = "<scene version=\"3.0.0\"><!-- fine --></scene>";
        assert!(matches!(lenient_markup(plain), std::borrow::Cow::Borrowed(_)));
        for cut in ["<", "<!", "<!-", "<!--", "<!-- a -", "<a b=\"x"] {
            assert!(matches!(lenient_markup(cut), std::borrow::Cow::Borrowed(_)), "{cut}");
        }
    }

    /// Attribute values Mitsuba reads and strict XML refuses (a bare `&`, an undefined entity, a `<`) are
    /// read as written; references XML defines, and (with a DTD) the DTD's, are read as before, and so is
    /// everything outside tags.
    #[test]
    fn attribute_values_are_read_as_mitsuba_reads_them() {
        let text =
            "<scene version=\"3.0.0\">\n<s a=\"R&D.png\" b='x &nbsp; &amp; &#65;&#x42; & y' c=\"1 < 2\" d=\"&\"/>\n\
                    <!-- & < --><![CDATA[ & ]]>\n</scene>";
        assert!(roxmltree::Document::parse(text).is_err(), "strict XML refuses it");
        let read = lenient_markup(text);
        assert_eq!(read.lines().count(), text.lines().count());
        let doc = roxmltree::Document::parse(&read).unwrap();
        let s = doc.descendants().find(|n| n.has_tag_name("s")).unwrap();
        let got: Vec<_> = ["a", "b", "c", "d"].iter().map(|k| s.attribute(*k).unwrap()).collect();
        assert_eq!(got, ["R&D.png", "x &nbsp; & AB & y", "1 < 2", "&"]);
        let dtd = "<!DOCTYPE scene [<!ENTITY n \"7\">]><scene v=\"&n; & m\"/>";
        let doc = parse_xml(&lenient_markup(dtd)).unwrap().root_element().attribute("v").map(str::to_string);
        assert_eq!(doc.as_deref(), Some("7 & m"));
        let plain = "<scene version=\"3.0.0\"><a b=\"&amp;\"/></scene>";
        assert!(matches!(lenient_markup(plain), std::borrow::Cow::Borrowed(_)));
    }

    /// A `<!DOCTYPE>` with an internal entity reads (Mitsuba reads it); entities that double ten times
    /// over are refused by the parser's own check, and a file of more nodes than `MAX_XML_NODES`.
    #[test]
    fn a_doctype_reads_and_entity_bombs_are_refused() {
        let scene = "<!DOCTYPE scene [<!ENTITY spp \"64\">]><scene version=\"3.0.0\"><integer name=\"n\" value=\"&spp;\"/></scene>";
        let doc = parse_xml(scene).unwrap();
        assert_eq!(
            doc.descendants().find(|n| n.has_tag_name("integer")).and_then(|n| n.attribute("value")),
            Some("64")
        );
        let mut bomb = String::from("<!DOCTYPE scene [<!ENTITY a0 \"<x/><x/>\">");
        for k in 1..32 {
            bomb += &format!("<!ENTITY a{k} \"&a{};&a{};\">", k - 1, k - 1);
        }
        bomb += "]><scene version=\"3.0.0\">&a31;</scene>";
        assert!(parse_xml(&bomb).is_err(), "2^32 nodes");
        let text_bomb = bomb.replace("<x/><x/>", "lol lol lol").replace("&a31;</scene>", "<s v=\"&a31;\"/></scene>");
        assert!(parse_xml(&text_bomb).is_err(), "2^31 × 11 bytes of text");
    }

    /// A declaration after blank lines, which Mitsuba reads and strict XML refuses, parses with its lines
    /// kept; one at the very start (after a byte-order mark or not) is left alone.
    #[test]
    fn a_declaration_after_blank_lines_is_read_as_mitsuba_reads_it() {
        let text = "\n  \n<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<scene version=\"3.0.0\"/>\n";
        assert!(roxmltree::Document::parse(text).is_err(), "strict XML refuses it");
        let read = lenient_declaration(text);
        assert_eq!(read.lines().count(), text.lines().count());
        let doc = roxmltree::Document::parse(&read).unwrap();
        assert_eq!(doc.root_element().tag_name().name(), "scene");
        assert_eq!(doc.text_pos_at(doc.root_element().range().start).row, 4);
        for fine in ["<?xml version=\"1.0\"?><scene/>", "\u{feff}<?xml version=\"1.0\"?><scene/>", "  <scene/>"] {
            assert!(matches!(lenient_declaration(fine), std::borrow::Cow::Borrowed(_)), "{fine}");
        }
    }
}
