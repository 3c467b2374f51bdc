//! The entity lump (lump 0) of a Quake 3 BSP: text blocks `{ "key" "value" ... }`.
//!
//! The parser is deliberately forgiving, like the game's own `COM_Parse`: it reads quoted
//! strings and braces, skips `//` comments and anything else it does not understand, and never
//! fails. Entities are only used for viewpoints, so a garbled lump costs viewpoints, not the map.

use glam::Vec3;

/// One entity: its key/value pairs in file order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Entity {
    /// Key/value pairs as written (keys may repeat; [`Entity::get`] returns the first).
    pub pairs: Vec<(String, String)>,
}

impl Entity {
    /// The value of the first pair with this key (keys compare case-insensitively, as in the
    /// game).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.pairs
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(key))
            .map(|(_, v)| v.as_str())
    }

    /// The `origin` key as a point, when it holds three finite numbers.
    pub fn origin(&self) -> Option<Vec3> {
        let mut it = self
            .get("origin")?
            .split_whitespace()
            .map(str::parse::<f32>);
        let mut next = || it.next()?.ok().filter(|v| v.is_finite());
        Some(Vec3::new(next()?, next()?, next()?))
    }

    /// True for player spawn points: `info_player_deathmatch`, `info_player_start` and the
    /// CTF respawn points `team_CTF_redspawn` / `team_CTF_bluespawn` (`team_CTF_*spawn`).
    /// `team_CTF_*player` (first spawn of a CTF match) is left out so the counts match
    /// SOURCES.md ("6 to 56" per map).
    pub fn is_spawn_point(&self) -> bool {
        let Some(class) = self.get("classname") else {
            return false;
        };
        let lower = class.to_ascii_lowercase();
        lower == "info_player_deathmatch"
            || lower == "info_player_start"
            || (lower.starts_with("team_ctf_") && lower.ends_with("spawn"))
    }
}

/// Tokens of the entity text.
#[derive(Debug, PartialEq)]
enum Token<'a> {
    Open,
    Close,
    Str(&'a str),
}

/// Splits the text into braces and quoted strings; unquoted words count as strings too (some
/// hand-edited maps leave quotes out), `//` comments are skipped.
fn tokens(text: &str) -> Vec<Token<'_>> {
    let mut out = Vec::new();
    let mut rest = text;
    loop {
        rest = rest.trim_start();
        let Some(c) = rest.chars().next() else {
            return out;
        };
        match c {
            '{' => {
                out.push(Token::Open);
                rest = &rest[1..];
            }
            '}' => {
                out.push(Token::Close);
                rest = &rest[1..];
            }
            '"' => {
                let body = &rest[1..];
                // An unterminated string runs to the end of the text.
                let end = body.find('"').unwrap_or(body.len());
                out.push(Token::Str(&body[..end]));
                rest = body.get(end + 1..).unwrap_or("");
            }
            _ if rest.starts_with("//") => {
                rest = rest.find('\n').map_or("", |i| &rest[i..]);
            }
            _ => {
                let end = rest
                    .find(|ch: char| ch.is_whitespace() || ch == '{' || ch == '}' || ch == '"')
                    .unwrap_or(rest.len());
                out.push(Token::Str(&rest[..end]));
                rest = &rest[end..];
            }
        }
    }
}

/// Parses the entity lump (up to its first NUL). Pairs outside braces and a dangling key are
/// ignored; an unclosed last block still counts as an entity.
pub(super) fn parse(lump: &[u8]) -> Vec<Entity> {
    let end = lump.iter().position(|&b| b == 0).unwrap_or(lump.len());
    let text = String::from_utf8_lossy(&lump[..end]);
    let mut entities = Vec::new();
    let mut current: Option<Entity> = None;
    let mut key: Option<&str> = None;
    for token in tokens(&text) {
        match token {
            Token::Open => {
                // A `{` inside a block (brush data in a .map, never in a BSP) starts over.
                if let Some(e) = current.take() {
                    entities.push(e);
                }
                current = Some(Entity::default());
                key = None;
            }
            Token::Close => {
                if let Some(e) = current.take() {
                    entities.push(e);
                }
                key = None;
            }
            Token::Str(s) => {
                if let Some(e) = current.as_mut() {
                    match key.take() {
                        None => key = Some(s),
                        Some(k) => e.pairs.push((k.to_string(), s.to_string())),
                    }
                }
            }
        }
    }
    if let Some(e) = current {
        entities.push(e);
    }
    entities
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_lump_has_no_entities() {
        assert!(parse(b"").is_empty());
        assert!(parse(b"\0{ \"a\" \"b\" }").is_empty());
    }

    #[test]
    fn spawn_point_origin_is_read() {
        let e = parse(
            b"{\n\"classname\" \"worldspawn\"\n}\n{\n\"origin\" \"1 -2.5 3\"\n\"classname\" \"info_player_deathmatch\"\n}\n\0junk",
        );
        assert_eq!(e.len(), 2);
        assert!(!e[0].is_spawn_point());
        assert!(e[1].is_spawn_point());
        assert_eq!(e[1].origin(), Some(Vec3::new(1.0, -2.5, 3.0)));
    }

    #[test]
    fn ctf_spawns_count_but_first_spawns_do_not() {
        let e =
            parse(b"{\"classname\" \"team_CTF_redspawn\"}{\"classname\" \"team_CTF_blueplayer\"}");
        assert!(e[0].is_spawn_point());
        assert!(!e[1].is_spawn_point());
    }

    #[test]
    fn bad_origin_is_none() {
        for text in [
            &b"{\"origin\" \"1 2\"}"[..],
            b"{\"origin\" \"1 x 3\"}",
            b"{\"origin\" \"1 2 nan\"}",
            b"{\"origin\"}",
        ] {
            let e = parse(text);
            assert_eq!(e[0].origin(), None, "{:?}", String::from_utf8_lossy(text));
        }
    }

    #[test]
    fn garbage_never_panics() {
        for text in [
            &b"}}}{{{\"\"\"//"[..],
            b"{\"unterminated",
            b"{ a b c }",
            &[0xff, 0xfe, b'{', b'"', 0xc3, b'"'],
        ] {
            let _ = parse(text);
        }
        let e = parse(b"{ origin \"4 5 6\" // comment \"x\"\n }");
        assert_eq!(e[0].origin(), Some(Vec3::new(4.0, 5.0, 6.0)));
        assert_eq!(e[0].pairs.len(), 1);
    }
}
