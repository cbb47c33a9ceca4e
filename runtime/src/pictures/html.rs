//! The demo's report page (`out/index.html`): images, tables and inline SVG
//! plots in one self-contained file beside the PNGs it links.

/// One block of the page.
pub enum Block {
    Heading(String),
    Paragraph(String),
    /// An image file (relative to the page) with its caption.
    Image {
        src: String,
        caption: String,
    },
    /// A header row, then rows of cells.
    Table {
        header: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    /// SVG text from [`super::plots`], inlined.
    Svg(String),
}

/// `&`, `<`, `>` and `"` as entities.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The whole page.
pub fn page(title: &str, blocks: &[Block]) -> String {
    let mut out = String::new();
    out.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    out.push_str(&format!("<title>{}</title>\n", escape(title)));
    out.push_str(
        "<style>body{font-family:DejaVu Sans,Helvetica,Arial,sans-serif;margin:2em;max-width:1400px;background:#fafafa;color:#222}\
         figure{display:inline-block;margin:0 1em 1em 0;vertical-align:top}figcaption{font-size:90%;color:#555}\
         img{max-width:100%;image-rendering:pixelated}table{border-collapse:collapse;margin:1em 0}\
         td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}th{background:#eee}\
         .plot{display:inline-block;margin:0 1em 1em 0}</style>\n</head>\n<body>\n",
    );
    out.push_str(&format!("<h1>{}</h1>\n", escape(title)));
    for b in blocks {
        match b {
            Block::Heading(h) => out.push_str(&format!("<h2>{}</h2>\n", escape(h))),
            Block::Paragraph(p) => out.push_str(&format!("<p>{}</p>\n", escape(p))),
            Block::Image { src, caption } => out.push_str(&format!(
                "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>\n",
                escape(src),
                escape(caption),
                escape(caption)
            )),
            Block::Table { header, rows } => {
                out.push_str("<table>\n<tr>");
                for h in header {
                    out.push_str(&format!("<th>{}</th>", escape(h)));
                }
                out.push_str("</tr>\n");
                for r in rows {
                    out.push_str("<tr>");
                    for c in r {
                        out.push_str(&format!("<td>{}</td>", escape(c)));
                    }
                    out.push_str("</tr>\n");
                }
                out.push_str("</table>\n");
            }
            Block::Svg(svg) => out.push_str(&format!("<div class=\"plot\">{svg}</div>\n")),
        }
    }
    out.push_str("</body>\n</html>\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pages_escape_text_and_keep_structure() {
        let p = page(
            "a < b",
            &[
                Block::Heading("H & I".into()),
                Block::Image { src: "x.png".into(), caption: "\"q\"".into() },
                Block::Table { header: vec!["f".into()], rows: vec![vec!["<1>".into()]] },
                Block::Svg("<svg></svg>".into()),
            ],
        );
        assert!(p.contains("<title>a &lt; b</title>") && p.contains("H &amp; I") && p.contains("&lt;1&gt;"));
        assert!(p.contains("<img src=\"x.png\"") && p.contains("&quot;q&quot;") && p.contains("<svg></svg>"));
        assert_eq!(p.matches("<tr>").count(), 2);
    }
}
