//! Who uses the engine (DESIGN §10): each API token belongs to a named user with a role.
//! Users come from a file (`--users`), one a line, `NAME ROLE TOKEN`: the role `user` or
//! `admin`, the token as itself or as `sha256:<hex>` of it; `#` starts a comment. The file is
//! read again when it changes (looked at at most once a second, on a request); a change
//! that does not read keeps the users as they were, with a warning. The single API token
//! (`--api-token`) is the user `default`, an admin; without any token (a loopback engine)
//! everyone is `default`.
//!
//! A user sees and acts on their own runs, batches and inputs, and has their own run
//! slots; an admin sees everyone's.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant, SystemTime};

use meshflow_api::server::token_matches;
use serde::Serialize;
use sha2::{Digest, Sha256};

/// The name of the `--api-token`'s user, and of everyone on a tokenless engine.
pub const DEFAULT_USER: &str = "default";
/// A shorter token is refused: it could be guessed.
pub const MIN_TOKEN_CHARS: usize = 16;
/// The users file is looked at (its modification time) at most this often.
const RELOAD_CHECK_EVERY: Duration = Duration::from_secs(1);
/// The largest users file read.
const MAX_USERS_FILE_BYTES: u64 = 1 << 20;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    User,
    Admin,
}

/// Who sends a request.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct User {
    pub name: String,
    pub role: Role,
}

impl User {
    pub fn default_admin() -> Self {
        Self { name: DEFAULT_USER.to_owned(), role: Role::Admin }
    }

    pub fn is_admin(&self) -> bool {
        self.role == Role::Admin
    }

    /// Whether this user may see and act on what `owner` owns.
    pub fn may_see(&self, owner: &str) -> bool {
        self.is_admin() || self.name == owner
    }
}

/// Why a users file does not read.
#[derive(Debug, thiserror::Error)]
pub enum UsersError {
    #[error("reading the users file {path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("the users file {path} is larger than {MAX_USERS_FILE_BYTES} bytes")]
    TooLarge { path: PathBuf },
    #[error("{path}, line {line}: {message}")]
    Line { path: PathBuf, line: usize, message: String },
}

/// How a token is written in the file.
#[derive(Clone, Debug)]
enum Secret {
    Plain(String),
    Sha256([u8; 32]),
}

impl Secret {
    fn matches(&self, given: &str) -> bool {
        match self {
            Secret::Plain(token) => token_matches(given, token),
            Secret::Sha256(digest) => {
                // Both sides are digests: the comparison's time says nothing of the token.
                let given: [u8; 32] = Sha256::digest(given.as_bytes()).into();
                blake3::hash(&given) == blake3::hash(digest)
            }
        }
    }
}

#[derive(Clone, Debug)]
struct Entry {
    user: User,
    secret: Secret,
}

/// The engine's users: the `--api-token`'s and those of the users file.
#[derive(Debug)]
pub struct Users {
    file: Option<PathBuf>,
    api_token: Option<String>,
    state: Mutex<Loaded>,
}

#[derive(Debug)]
struct Loaded {
    entries: Vec<Entry>,
    modified: Option<SystemTime>,
    checked: Instant,
}

impl Users {
    /// The users of `file` (refused now if it does not read) and the `api_token`'s.
    pub fn open(file: Option<&Path>, api_token: Option<String>) -> Result<Self, UsersError> {
        let (entries, modified) = match file {
            Some(path) => (read(path, api_token.is_some())?, modified(path)),
            None => (Vec::new(), None),
        };
        Ok(Self {
            file: file.map(Path::to_owned),
            api_token,
            state: Mutex::new(Loaded { entries, modified, checked: Instant::now() }),
        })
    }

    /// Whether any token is needed: without a users file and an API token, none is.
    pub fn required(&self) -> bool {
        self.file.is_some() || self.api_token.is_some()
    }

    /// The user a bearer token belongs to; `default` when no token is needed. `None`: the
    /// token is nobody's (or missing).
    pub fn authenticate(&self, given: Option<&str>) -> Option<User> {
        if !self.required() {
            return Some(User::default_admin());
        }
        let given = given?;
        if self.api_token.as_deref().is_some_and(|token| token_matches(given, token)) {
            return Some(User::default_admin());
        }
        self.reload_if_changed();
        let state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        state.entries.iter().find(|entry| entry.secret.matches(given)).map(|e| e.user.clone())
    }

    /// The role of the user called `name`, if there is one.
    pub fn role_of(&self, name: &str) -> Option<Role> {
        if name == DEFAULT_USER && (self.api_token.is_some() || !self.required()) {
            return Some(Role::Admin);
        }
        self.reload_if_changed();
        let state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        state.entries.iter().find(|e| e.user.name == name).map(|e| e.user.role)
    }

    /// Reads the file again if it changed since it was last read (at most once a second).
    fn reload_if_changed(&self) {
        let Some(path) = &self.file else { return };
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if state.checked.elapsed() < RELOAD_CHECK_EVERY {
            return;
        }
        state.checked = Instant::now();
        let now = modified(path);
        if now.is_none() || now == state.modified {
            return;
        }
        state.modified = now;
        match read(path, self.api_token.is_some()) {
            Ok(entries) => {
                tracing::info!("users reloaded from {} ({} users)", path.display(), entries.len());
                state.entries = entries;
            }
            Err(error) => tracing::warn!("users not reloaded, the old ones stay: {error}"),
        }
    }
}

/// A token in the `sha256:<hex>` form a users file takes, so the file need not hold it.
pub fn hashed(token: &str) -> String {
    format!("sha256:{}", hex::encode(Sha256::digest(token.as_bytes())))
}

fn modified(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

/// Reads a users file; `default_taken`: the `--api-token` is the user `default`.
fn read(path: &Path, default_taken: bool) -> Result<Vec<Entry>, UsersError> {
    let io = |source| UsersError::Io { path: path.to_owned(), source };
    if std::fs::metadata(path).map_err(io)?.len() > MAX_USERS_FILE_BYTES {
        return Err(UsersError::TooLarge { path: path.to_owned() });
    }
    let text = std::fs::read_to_string(path).map_err(io)?;
    parse(&text, default_taken).map_err(|(line, message)| UsersError::Line {
        path: path.to_owned(),
        line,
        message,
    })
}

/// The entries of a users file's text, or the first bad line's number and what is wrong.
fn parse(text: &str, default_taken: bool) -> Result<Vec<Entry>, (usize, String)> {
    let mut entries: Vec<Entry> = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let number = index + 1;
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let [name, role, token] = fields[..] else {
            let message = format!("expected NAME ROLE TOKEN, found {} fields", fields.len());
            return Err((number, message));
        };
        let plain_name = name.chars().all(|c| c.is_ascii_alphanumeric() || "._-@".contains(c))
            && name.len() <= 64;
        if !plain_name {
            let message = "a name is letters, digits and . _ - @ (at most 64)".to_owned();
            return Err((number, message));
        }
        let role = match role {
            "user" => Role::User,
            "admin" => Role::Admin,
            other => {
                let shown: String = other.chars().take(20).collect();
                return Err((number, format!("the role is user or admin, not \"{shown}\"")));
            }
        };
        let secret = match token.strip_prefix("sha256:") {
            Some(digest) => {
                let bytes = hex::decode(digest).ok().and_then(|b| <[u8; 32]>::try_from(b).ok());
                let message = "sha256: needs the 64 hex digits of the token's SHA-256";
                Secret::Sha256(bytes.ok_or_else(|| (number, message.to_owned()))?)
            }
            None if token.chars().count() < MIN_TOKEN_CHARS => {
                let message = format!(
                    "the token has {} characters; at least {MIN_TOKEN_CHARS} are needed",
                    token.chars().count()
                );
                return Err((number, message));
            }
            None => Secret::Plain(token.to_owned()),
        };
        if entries.iter().any(|e| e.user.name == name) || (default_taken && name == DEFAULT_USER) {
            let message = match name {
                DEFAULT_USER => "\"default\" is the --api-token's user".to_owned(),
                _ => format!("the user \"{name}\" is named twice"),
            };
            return Err((number, message));
        }
        entries.push(Entry { user: User { name: name.to_owned(), role }, secret });
    }
    Ok(entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ANNA: &str = "anna-token-0123456789";

    #[test]
    fn a_users_file_names_users_by_token_or_its_digest() {
        let text = format!(
            "# the lab\n\nanna user {ANNA}\nboss admin {}  # hashed\n",
            hashed("boss-token-0123456789")
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("users");
        std::fs::write(&path, text).unwrap();
        let users = Users::open(Some(&path), Some("api-token-0123456789".into())).unwrap();
        let anna = users.authenticate(Some(ANNA)).unwrap();
        assert_eq!((anna.name.as_str(), anna.role), ("anna", Role::User));
        let boss = users.authenticate(Some("boss-token-0123456789")).unwrap();
        assert_eq!((boss.name.as_str(), boss.role), ("boss", Role::Admin));
        assert_eq!(users.authenticate(Some("api-token-0123456789")), Some(User::default_admin()));
        assert_eq!(users.authenticate(Some("nobody-0123456789")), None);
        assert_eq!(users.authenticate(None), None);
        let open = Users::open(None, None).unwrap();
        assert_eq!(open.authenticate(None), Some(User::default_admin()));
    }

    #[test]
    fn bad_lines_are_refused_with_their_number() {
        let cases = [
            ("anna user short", 1, "at least 16"),
            ("# c\nanna boss anna-token-0123456789", 2, "user or admin"),
            ("anna user", 1, "NAME ROLE TOKEN"),
            ("anna user sha256:abcd", 1, "64 hex"),
            ("a user anna-token-0123456789\na admin boss-token-0123456789", 2, "twice"),
            ("default admin anna-token-0123456789", 1, "--api-token"),
            ("an/na user anna-token-0123456789", 1, "letters"),
        ];
        for (text, line, words) in cases {
            let (number, message) = parse(text, true).expect_err(text);
            assert_eq!(number, line, "{text}");
            assert!(message.contains(words), "{text}: {message}");
        }
    }

    #[test]
    fn a_changed_file_is_read_again_and_a_bad_change_keeps_the_old_users() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("users");
        std::fs::write(&path, format!("anna user {ANNA}\n")).unwrap();
        let users = Users::open(Some(&path), None).unwrap();
        assert!(users.authenticate(Some(ANNA)).is_some());
        let later = |users: &Users| {
            let mut state = users.state.lock().unwrap();
            state.checked -= RELOAD_CHECK_EVERY;
            state.modified = Some(SystemTime::UNIX_EPOCH);
        };
        std::fs::write(&path, "bert user bert-token-0123456789\n").unwrap();
        later(&users);
        assert!(users.authenticate(Some(ANNA)).is_none());
        assert_eq!(users.authenticate(Some("bert-token-0123456789")).unwrap().name, "bert");
        std::fs::write(&path, "bert user short\n").unwrap();
        later(&users);
        assert_eq!(users.authenticate(Some("bert-token-0123456789")).unwrap().name, "bert");
    }
}
