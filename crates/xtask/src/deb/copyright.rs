//! `/usr/share/doc/acc/copyright` in Debian's machine-readable format (DEP-5), from the
//! workspace's license expression (`license` in Cargo.toml).

use anyhow::bail;

/// The license texts this file knows: (SPDX id, the paragraph's body, each line indented).
const LICENSES: [(&str, &str); 2] = [
    (
        "MIT",
        " Permission is hereby granted, free of charge, to any person obtaining a copy
 of this software and associated documentation files (the \"Software\"), to deal
 in the Software without restriction, including without limitation the rights
 to use, copy, modify, merge, publish, distribute, sublicense, and/or sell
 copies of the Software, and to permit persons to whom the Software is
 furnished to do so, subject to the following conditions:
 .
 The above copyright notice and this permission notice shall be included in all
 copies or substantial portions of the Software.
 .
 THE SOFTWARE IS PROVIDED \"AS IS\", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR
 IMPLIED, INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY,
 FITNESS FOR A PARTICULAR PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE
 AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM, DAMAGES OR OTHER
 LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
 OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE
 SOFTWARE.
",
    ),
    (
        "Apache-2.0",
        " On Debian systems, the full text of the Apache License, Version 2.0, is in
 /usr/share/common-licenses/Apache-2.0.
",
    ),
];

/// The copyright file for the license expression `spdx` (`MIT OR Apache-2.0`); an id
/// without a known text is an error naming it.
pub fn text(spdx: &str) -> anyhow::Result<String> {
    let ids: Vec<&str> = spdx.split(" OR ").map(str::trim).collect();
    let mut paragraphs = String::new();
    for id in &ids {
        let Some((_, body)) = LICENSES.iter().find(|(known, _)| known == id) else {
            let known: Vec<&str> = LICENSES.iter().map(|(k, _)| *k).collect();
            bail!(
                "license {id} (workspace license `{spdx}`): no text for the copyright file; known: {}",
                known.join(", ")
            );
        };
        paragraphs.push_str(&format!("\nLicense: {id}\n{body}"));
    }
    Ok(format!(
        "Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/\n\
         Upstream-Name: acc\n\
         \n\
         Files: *\n\
         Copyright: the acc developers\n\
         License: {}\n{paragraphs}",
        ids.join(" or ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_license_of_the_expression_gets_its_paragraph() {
        let t = text("MIT OR Apache-2.0").expect("known");
        assert!(t.contains("Files: *\nCopyright: the acc developers\nLicense: MIT or Apache-2.0\n"));
        assert!(t.contains("\nLicense: MIT\n Permission is hereby granted"));
        assert!(t.contains("\nLicense: Apache-2.0\n On Debian systems"));
        let e = text("GPL-2.0").expect_err("unknown");
        assert!(e.to_string().contains("license GPL-2.0"), "{e}");
    }
}
