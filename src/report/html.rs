//! `report.html` (and a study's `study.html`): one self-contained page per run, made from
//! the same markdown as `report.md` so the two never disagree. The markdown is rendered by
//! `pulldown-cmark` (CommonMark with tables); two things are this page's own: every figure
//! the markdown shows alone in a paragraph (`![caption](name.svg)`) is inlined as vector SVG
//! with links to its PNG and PDF, and the block after a `<!-- fold: TITLE -->` comment is
//! folded into a `<details>` element (the diagnostics). Every heading has an anchor, the
//! page opens with a table of contents of its sections, figures are numbered, and a wide
//! table scrolls sideways inside its own box, so that the page fits a phone's width. No
//! script, no external resource.

use pulldown_cmark::{CowStr, Event, Options, Parser, Tag, TagEnd};
use std::path::Path;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The SVG file `name` in `dir`, ready to sit inline: its element ids prefixed with
/// `prefix` (several figures share one page), or a note where it is missing.
fn inline_svg(dir: &Path, name: &str, prefix: &str) -> String {
    match std::fs::read_to_string(dir.join(name)) {
        Ok(svg) => {
            let start = svg.find("<svg").unwrap_or(0);
            svg[start..]
                .replace("id=\"", &format!("id=\"{prefix}"))
                .replace("url(#", &format!("url(#{prefix}"))
        }
        Err(e) => format!("<p class=\"missing\">figure {} not found: {e}</p>", escape(name)),
    }
}

/// The caption's HTML: the image's alt text as markdown inline (code, emphasis).
fn caption(alt: &str) -> String {
    let mut out = String::new();
    let events = Parser::new_ext(alt, Options::empty())
        .filter(|e| !matches!(e, Event::Start(Tag::Paragraph) | Event::End(TagEnd::Paragraph)));
    pulldown_cmark::html::push_html(&mut out, events);
    out.trim().to_string()
}

/// The `<figure>` of a paragraph that holds one image and nothing else: the events
/// `events[at..]` are `Start(Paragraph), Start(Image), …, End(Image), End(Paragraph)`.
/// Returns the figure's HTML and the number of events it took.
fn figure(events: &[Event], at: usize, dir: &Path, number: usize) -> Option<(String, usize)> {
    let Some(Event::Start(Tag::Image { dest_url, .. })) = events.get(at + 1) else {
        return None;
    };
    let close = at
        + 2
        + events[at + 2..]
            .iter()
            .position(|e| matches!(e, Event::End(TagEnd::Image)))?;
    if !matches!(events.get(close + 1), Some(Event::End(TagEnd::Paragraph))) {
        return None;
    }
    // The alt text back as markdown: its text and code spans.
    let mut alt = String::new();
    for e in &events[at + 2..close] {
        match e {
            Event::Text(t) => alt += t,
            Event::Code(c) => alt += &format!("`{c}`"),
            _ => {}
        }
    }
    let src = dest_url.to_string();
    let svg = inline_svg(dir, &src, &format!("fig{number}-"));
    let stem = src.trim_end_matches(".svg");
    let html = format!(
        "<figure id=\"figure-{number}\">\n{svg}<figcaption><a class=\"number\" href=\"#figure-{number}\">Figure \
         {number}.</a> {} <span class=\"files\">(<a href=\"{s}\">SVG</a>, <a href=\"{stem}.png\">PNG</a>, \
         <a href=\"{stem}.pdf\">PDF</a>)</span></figcaption>\n</figure>\n",
        caption(&alt),
        s = escape(&src),
        stem = escape(stem)
    );
    Some((html, close + 2 - at))
}

/// Render the markdown `md` (as the report writes it) to a whole HTML page titled
/// `title`, with the figures it links read from `dir`.
pub fn page(title: &str, md: &str, dir: &Path) -> std::io::Result<String> {
    let mut events: Vec<Event> = Parser::new_ext(md, Options::ENABLE_TABLES).collect();
    let toc = anchor_headings(&mut events);
    let mut out: Vec<Event> = Vec::with_capacity(events.len());
    let mut figures = 0usize;
    // Block nesting depth, and the depth at which an open `<details>` closes.
    let mut depth = 0usize;
    let mut fold_pending: Option<String> = None;
    let mut fold_open = false;
    let mut i = 0;
    while i < events.len() {
        let e = &events[i];
        if let Event::Html(h) = e {
            if let Some(t) = h.trim().strip_prefix("<!-- fold:").and_then(|t| t.strip_suffix("-->")) {
                fold_pending = Some(t.trim().to_string());
                i += 1;
                continue;
            }
        }
        let starts_block = matches!(e, Event::Start(t) if is_block(t));
        if starts_block && depth == 0 && !matches!(e, Event::Start(Tag::HtmlBlock)) {
            if let Some(t) = fold_pending.take() {
                out.push(Event::Html(CowStr::from(format!(
                    "<details><summary>{}</summary>\n",
                    caption(&t)
                ))));
                fold_open = true;
            }
        }
        if matches!(e, Event::Start(Tag::Paragraph)) {
            if let Some((html, taken)) = figure(&events, i, dir, figures + 1) {
                figures += 1;
                out.push(Event::Html(CowStr::from(html)));
                i += taken;
                close_fold(depth, &mut fold_open, &mut out);
                continue;
            }
        }
        match e {
            Event::Start(t) if is_block(t) => depth += 1,
            Event::End(t) if is_block_end(t) => depth -= 1,
            _ => {}
        }
        if matches!(e, Event::Start(Tag::Table(_))) {
            out.push(Event::Html(CowStr::from("<div class=\"wide\">")));
        }
        out.push(e.clone());
        if matches!(e, Event::End(TagEnd::Table)) {
            out.push(Event::Html(CowStr::from("</div>\n")));
        }
        // The contents after the page's title.
        if matches!(e, Event::End(TagEnd::Heading(pulldown_cmark::HeadingLevel::H1))) {
            out.push(Event::Html(CowStr::from(toc.clone())));
        }
        if matches!(e, Event::End(t) if is_block_end(t)) && !matches!(e, Event::End(TagEnd::HtmlBlock)) {
            close_fold(depth, &mut fold_open, &mut out);
        }
        i += 1;
    }
    let mut body = String::new();
    pulldown_cmark::html::push_html(&mut body, out.into_iter());
    Ok(format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{}</title>\n<style>{STYLE}</style>\n\
         </head>\n<body>\n<main>\n{body}</main>\n</body>\n</html>\n",
        escape(title)
    ))
}

/// Give every heading an id from its text (`estimates`, `validation-2` for a second one)
/// and return the table of contents of the sections (level 2) as HTML.
fn anchor_headings(events: &mut [Event]) -> String {
    let mut used: Vec<String> = Vec::new();
    let mut entries = Vec::new();
    for k in 0..events.len() {
        let Event::Start(Tag::Heading { level, .. }) = &events[k] else {
            continue;
        };
        let level = *level;
        let mut text = String::new();
        for e in &events[k + 1..] {
            match e {
                Event::Text(t) | Event::Code(t) => text += t,
                Event::End(TagEnd::Heading(_)) => break,
                _ => {}
            }
        }
        let base: String = text
            .to_lowercase()
            .chars()
            .map(|c| if c.is_alphanumeric() { c } else { '-' })
            .collect::<String>()
            .split('-')
            .filter(|w| !w.is_empty())
            .collect::<Vec<_>>()
            .join("-");
        let base = if base.is_empty() { "section".to_string() } else { base };
        let mut id = base.clone();
        let mut n = 1;
        while used.contains(&id) {
            n += 1;
            id = format!("{base}-{n}");
        }
        used.push(id.clone());
        if let Event::Start(Tag::Heading { id: slot, .. }) = &mut events[k] {
            *slot = Some(CowStr::from(id.clone()));
        }
        if level == pulldown_cmark::HeadingLevel::H2 {
            entries.push(format!("<li><a href=\"#{}\">{}</a></li>", escape(&id), escape(&text)));
        }
    }
    if entries.len() < 2 {
        return String::new();
    }
    format!(
        "<nav class=\"toc\"><strong>Contents</strong><ol>{}</ol></nav>\n",
        entries.join("")
    )
}

/// Close an open `<details>` once the folded block has ended (back at the top level).
fn close_fold(depth: usize, open: &mut bool, out: &mut Vec<Event>) {
    if *open && depth == 0 {
        out.push(Event::Html(CowStr::from("</details>\n")));
        *open = false;
    }
}

fn is_block(t: &Tag) -> bool {
    matches!(
        t,
        Tag::Paragraph
            | Tag::Heading { .. }
            | Tag::BlockQuote(_)
            | Tag::CodeBlock(_)
            | Tag::HtmlBlock
            | Tag::List(_)
            | Tag::Table(_)
    )
}

fn is_block_end(t: &TagEnd) -> bool {
    matches!(
        t,
        TagEnd::Paragraph
            | TagEnd::Heading(_)
            | TagEnd::BlockQuote(_)
            | TagEnd::CodeBlock
            | TagEnd::HtmlBlock
            | TagEnd::List(_)
            | TagEnd::Table
    )
}

const STYLE: &str = "
body { font-family: 'DejaVu Sans', Verdana, Arial, Helvetica, sans-serif; color: #1a1a1a; margin: 0; background: #fafafa; }
main { max-width: 1240px; margin: 0 auto; padding: 1.5em 2em 4em; background: white; }
h1 { font-size: 1.6em; border-bottom: 2px solid #333; padding-bottom: .3em; }
h2 { font-size: 1.3em; margin-top: 2em; border-bottom: 1px solid #ccc; }
h3 { font-size: 1.1em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: .8em 0; font-size: .9em; }
.wide { overflow-x: auto; max-width: 100%; }
p, li, td, code { overflow-wrap: anywhere; }
.toc { background: #f6f6f6; border: 1px solid #e0e0e0; padding: .5em 1em; margin: 1em 0; font-size: .95em; }
.toc ol { margin: .3em 0; padding-left: 1.6em; columns: 2; }
a.number { color: inherit; font-weight: bold; text-decoration: none; }
@media (max-width: 700px) {
  main { padding: 1em .7em 3em; }
  .toc ol { columns: 1; }
  h1 { font-size: 1.3em; }
}
th, td { border: 1px solid #d0d0d0; padding: .25em .6em; }
thead th { background: #f0f0f0; }
tbody tr:nth-child(even) { background: #fafafa; }
code { font-family: 'DejaVu Sans Mono', Menlo, Consolas, monospace; font-size: .92em; background: #f3f3f3; padding: 0 .2em; }
pre { background: #f6f6f6; border: 1px solid #e0e0e0; padding: .7em; overflow-x: auto; font-size: .85em; }
pre code { background: none; padding: 0; font-size: inherit; }
figure { margin: 1.2em 0; }
figure svg { max-width: 100%; height: auto; display: block; }
figcaption { font-size: .9em; color: #444; margin-top: .3em; }
.files { color: #777; }
details { margin: .5em 0 1em; border-left: 3px solid #ddd; padding-left: .8em; }
summary { cursor: pointer; color: #333; }
blockquote { border-left: 4px solid #c33; margin: 1em 0; padding: .3em 1em; background: #fff5f5; }
.missing { color: #a00; }
";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_figures_and_folds_render() {
        let dir = tempfile::tempdir().expect("tempdir");
        std::fs::write(
            dir.path().join("a.svg"),
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><clipPath id=\"clip1\"/><g clip-path=\"url(#clip1)\"/></svg>",
        )
        .expect("write");
        let md = "# T\n\n## Intro\n\nSome **bold** `x<y`.\n\n| a | b |\n|---|---:|\n| 1 | 2 |\n\n![The caption](a.svg)\n\n\
                  <!-- fold: diagnostics -->\n- rank 3/3\n- time 1 s\n\n## Next\n\n<!-- fold: steps -->\n```\na | b < c\n```\n\nAfter.\n";
        let html = page("t", md, dir.path()).expect("page");
        assert!(
            html.contains("<table>") && html.contains("<td style=\"text-align: right\">2</td>"),
            "{html}"
        );
        assert!(html.contains("<strong>bold</strong>") && html.contains("<code>x&lt;y</code>"));
        assert!(html.contains("id=\"fig1-clip1\"") && html.contains("url(#fig1-clip1)"));
        assert!(html.contains("<details><summary>diagnostics</summary>\n<ul>"));
        assert!(html.contains("</ul>\n</details>\n<h2 id=\"next\">Next</h2>"), "{html}");
        assert!(
            html.contains(
                "<details><summary>steps</summary>\n<pre><code>a | b &lt; c\n</code></pre>\n</details>\n<p>After.</p>"
            ),
            "{html}"
        );
        assert!(
            html.contains("<figure id=\"figure-1\">")
                && html.contains("<figcaption><a class=\"number\" href=\"#figure-1\">Figure 1.</a> The caption <span"),
            "{html}"
        );
        // Anchors, the contents after the title (two sections), tables in a scroll box.
        assert!(
            html.contains("<h1 id=\"t\">T</h1>\n<nav class=\"toc\"><strong>Contents</strong><ol>"),
            "{html}"
        );
        assert!(html.contains("<li><a href=\"#next\">Next</a></li>") && html.contains("<h2 id=\"next\">"));
        assert!(
            html.contains("<div class=\"wide\"><table>") && html.contains("</table>\n</div>"),
            "{html}"
        );
    }
}
