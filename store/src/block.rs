//! Generated blocks of hand-written files: the text between a start and an
//! end marker line (e.g. `<!-- claims:start -->` and `<!-- claims:end -->`
//! in a README), replaced by a program while everything around it stays
//! byte for byte.

/// `text` with the lines strictly between the first line equal to `start`
/// and the next line after it equal to `end` replaced by `body`, or `None`
/// when the two lines are not there in that order. A marker counts only as
/// a whole line of its own (trailing whitespace and `\r` ignored): a marker
/// quoted in prose, as `` `<!-- claims:start -->` `` in a sentence, is text.
pub fn with_block(text: &str, start: &str, end: &str, body: &str) -> Option<String> {
    let (start, end) = (start.trim_end(), end.trim_end());
    let mut offset = 0;
    let mut inside = None;
    for line in text.split_inclusive('\n') {
        let bare = line.trim_end();
        match inside {
            None if bare == start => inside = Some(offset + line.len()),
            Some(from) if bare == end => {
                let mut out = String::with_capacity(text.len() + body.len());
                out.push_str(&text[..from]);
                // a start marker on the file's last line without its newline
                if !text[..from].ends_with('\n') {
                    out.push('\n');
                }
                out.push_str(body);
                if !body.is_empty() && !body.ends_with('\n') {
                    out.push('\n');
                }
                out.push_str(&text[offset..]);
                return Some(out);
            }
            _ => {}
        }
        offset += line.len();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_between_whole_marker_lines_only() {
        let text = "intro `<!-- s -->` quoted\n<!-- s -->\nold\n<!-- e -->\ntail `<!-- e -->`\n";
        assert_eq!(
            with_block(text, "<!-- s -->", "<!-- e -->", "new\n").as_deref(),
            Some("intro `<!-- s -->` quoted\n<!-- s -->\nnew\n<!-- e -->\ntail `<!-- e -->`\n")
        );
        // a body without its last newline gets one; CRLF markers count
        assert_eq!(
            with_block(
                "a\r\n<!-- s -->\r\nx\r\n<!-- e -->\r\n",
                "<!-- s -->",
                "<!-- e -->",
                "y"
            )
            .as_deref(),
            Some("a\r\n<!-- s -->\r\ny\n<!-- e -->\r\n")
        );
        for missing in [
            "no markers\n",
            "<!-- e -->\n<!-- s -->\n",
            "text <!-- s -->\n<!-- e -->\n",
            "<!-- s -->\nonly start\n",
        ] {
            assert_eq!(
                with_block(missing, "<!-- s -->", "<!-- e -->", "z\n"),
                None,
                "{missing}"
            );
        }
    }
}
