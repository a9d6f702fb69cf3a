//! Splicing a generated table into a markdown document, between its markers.

use std::path::Path;

use anyhow::{bail, Context};

/// Replace the text between `<!-- {name}:begin -->` and `<!-- {name}:end -->` in `doc` by
/// `table` (the markers stay).
pub fn replace_between(doc: &Path, name: &str, table: &str) -> anyhow::Result<()> {
    let begin = format!("<!-- {name}:begin -->");
    let end = format!("<!-- {name}:end -->");
    let text = std::fs::read_to_string(doc).with_context(|| format!("{}", doc.display()))?;
    let (Some(b), Some(e)) = (text.find(&begin), text.find(&end)) else {
        bail!(
            "{}: no `{begin}` … `{end}` markers to put the table between",
            doc.display()
        );
    };
    if e < b {
        bail!("{}: `{end}` comes before `{begin}`", doc.display());
    }
    let new = format!("{}{begin}\n{table}{}", &text[..b], &text[e..]);
    std::fs::write(doc, new).with_context(|| format!("{}", doc.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_doc_table_goes_between_the_markers() {
        let dir = tempfile::tempdir().expect("tmp");
        let doc = dir.path().join("r.md");
        std::fs::write(
            &doc,
            "# R\n<!-- fault-matrix:begin -->\nold\n<!-- fault-matrix:end -->\ntail\n",
        )
        .expect("write");
        replace_between(&doc, "fault-matrix", "| new |\n").expect("update");
        let text = std::fs::read_to_string(&doc).expect("read");
        assert_eq!(
            text,
            "# R\n<!-- fault-matrix:begin -->\n| new |\n<!-- fault-matrix:end -->\ntail\n"
        );
        std::fs::write(&doc, "no markers").expect("write");
        assert!(replace_between(&doc, "fault-matrix", "x").is_err());
    }
}
