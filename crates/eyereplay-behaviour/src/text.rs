//! The text a synthetic reader reads: words laid out in lines.
//!
//! The bundled text is in the public domain: Abraham Lincoln's Gettysburg
//! Address (1863, the Bliss copy) and the opening of the United States
//! Declaration of Independence (1776). A config can name its own UTF-8 text
//! file instead (`text = "answer.txt"`).
//!
//! Word frequency enters the fixation durations as in E-Z Reader
//! (Reichle, Warren & McConnell 2009): a word's familiarity check takes
//! `alpha1 - alpha2 ln f`. Lacking a frequency lexicon, a word is "frequent"
//! when it is one of the 100 most common English words (the function words
//! that make up about half of running text), given f = 3000 per million,
//! and otherwise f = 30 per million.

/// The bundled public-domain text.
pub const BUNDLED_TEXT: &str = include_str!("../text/public_domain.txt");

/// The 100 most common English words (function words and the commonest
/// verbs), lower case.
const FREQUENT: &[&str] = &[
    "the", "of", "and", "a", "to", "in", "is", "you", "that", "it", "he", "was", "for", "on",
    "are", "as", "with", "his", "they", "i", "at", "be", "this", "have", "from", "or", "one",
    "had", "by", "word", "but", "not", "what", "all", "were", "we", "when", "your", "can", "said",
    "there", "use", "an", "each", "which", "she", "do", "how", "their", "if", "will", "up",
    "other", "about", "out", "many", "then", "them", "these", "so", "some", "her", "would", "make",
    "like", "him", "into", "time", "has", "look", "two", "more", "write", "go", "see", "number",
    "no", "way", "could", "people", "my", "than", "first", "been", "who", "its", "now", "long",
    "down", "day", "did", "get", "come", "made", "may", "part", "our", "us", "here", "should",
];

/// Frequency per million given to a frequent / any other word.
pub const FREQUENT_PER_MILLION: f64 = 3000.0;
pub const OTHER_PER_MILLION: f64 = 30.0;

/// One word on a line.
#[derive(Clone, Debug, PartialEq)]
pub struct Word {
    pub line: usize,
    /// First character's position on its line.
    pub start: usize,
    /// Characters on the line (letters and attached punctuation).
    pub len: usize,
    /// Letters alone: what word-length effects count.
    pub letters: usize,
    pub per_million: f64,
}

impl Word {
    /// Centre of the word, in character positions.
    pub fn centre(&self) -> f64 {
        self.start as f64 + self.len as f64 / 2.0
    }
}

/// A text wrapped to lines of at most `line_chars` characters (a longer
/// word gets a line of its own).
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub words: Vec<Word>,
    pub lines: usize,
}

/// Letters of a token, for its length: punctuation does not count.
fn letters(token: &str) -> usize {
    token.chars().filter(|c| c.is_alphanumeric()).count().max(1)
}

/// Wraps `text` greedily into lines of at most `line_chars` characters.
pub fn layout(text: &str, line_chars: usize) -> Layout {
    let line_chars = line_chars.max(1);
    let mut words = Vec::new();
    let (mut line, mut col) = (0usize, 0usize);
    for token in text.split_whitespace() {
        let w = token.chars().count();
        if col > 0 && col + 1 + w > line_chars {
            line += 1;
            col = 0;
        }
        let start = if col == 0 { 0 } else { col + 1 };
        let lower: String = token
            .chars()
            .filter(|c| c.is_alphanumeric() || *c == '\'')
            .flat_map(char::to_lowercase)
            .collect();
        words.push(Word {
            line,
            start,
            len: w.max(1),
            letters: letters(token),
            per_million: if FREQUENT.contains(&lower.as_str()) {
                FREQUENT_PER_MILLION
            } else {
                OTHER_PER_MILLION
            },
        });
        col = start + w;
    }
    Layout {
        lines: if words.is_empty() { 0 } else { line + 1 },
        words,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_greedily_and_keeps_positions() {
        let l = layout("aa bbb cccc d", 8);
        let pos: Vec<(usize, usize, usize)> =
            l.words.iter().map(|w| (w.line, w.start, w.len)).collect();
        // "aa bbb" (6) fits; "cccc" would make 11 > 8: new line; "cccc d" 6.
        assert_eq!(pos, vec![(0, 0, 2), (0, 3, 3), (1, 0, 4), (1, 5, 1)]);
        assert_eq!(l.lines, 2);
        assert_eq!(l.words[1].centre(), 4.5);
    }

    #[test]
    fn frequent_words_are_marked() {
        let l = layout("The nation, conceived", 80);
        assert_eq!(l.words[0].per_million, FREQUENT_PER_MILLION);
        assert_eq!(l.words[1].per_million, OTHER_PER_MILLION);
        assert_eq!(l.words[1].letters, 6);
        assert_eq!(l.words[1].len, 7);
    }

    #[test]
    fn bundled_text_is_long_enough() {
        assert!(BUNDLED_TEXT.split_whitespace().count() > 450);
    }
}
