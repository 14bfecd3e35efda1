//! A small blocking Chrome DevTools Protocol client over one WebSocket
//! (tungstenite). Commands can be sent without waiting for their answer,
//! which the frame loop needs: with begin-frame control, a mouse event is
//! acknowledged only after the next `beginFrame`, so the two must be in
//! flight together.
//!
//! Events are kept only when they matter to the capture (a short list), so
//! a chatty page cannot grow memory; events that end a session (crash,
//! detach, main-frame navigation once armed) are turned into an error that
//! every later wait returns.

use crate::{BrowserError, RemoteError};
use serde_json::{json, Value};
use std::collections::{HashMap, VecDeque};
use std::net::TcpStream;
use std::time::{Duration, Instant};
use tungstenite::{Message, WebSocket};

/// Events the capture waits for; all others are dropped on arrival.
const KEPT_EVENTS: &[&str] = &[
    "Emulation.virtualTimeBudgetExpired",
    "Page.loadEventFired",
    "Target.attachedToTarget",
];

pub struct Cdp {
    ws: WebSocket<TcpStream>,
    next_id: u64,
    responses: HashMap<u64, Result<Value, RemoteError>>,
    events: VecDeque<(String, Value)>,
    /// Set by an event that ends the session; returned by every wait.
    fatal: Option<String>,
    fatal_kind: FatalKind,
    /// Once true, a main-frame navigation is fatal.
    pub watch_navigation: bool,
    pub timeout: Duration,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum FatalKind {
    None,
    Crash,
    Navigation,
    Disconnect,
}

impl Cdp {
    /// Connects to a `ws://host:port/path` DevTools endpoint.
    pub fn connect(ws_url: &str, timeout: Duration) -> Result<Cdp, BrowserError> {
        let hostport = ws_url
            .strip_prefix("ws://")
            .and_then(|r| r.split('/').next())
            .ok_or_else(|| BrowserError::protocol("connect", format!("bad endpoint {ws_url}")))?;
        let stream = TcpStream::connect(hostport)
            .map_err(|e| BrowserError::protocol("connect", format!("{hostport}: {e}")))?;
        stream
            .set_nodelay(true)
            .map_err(|e| BrowserError::protocol("connect", e.to_string()))?;
        stream
            .set_read_timeout(Some(timeout))
            .map_err(|e| BrowserError::protocol("connect", e.to_string()))?;
        let (ws, _) = tungstenite::client(ws_url, stream)
            .map_err(|e| BrowserError::protocol("connect", e.to_string()))?;
        Ok(Cdp {
            ws,
            next_id: 1,
            responses: HashMap::new(),
            events: VecDeque::new(),
            fatal: None,
            fatal_kind: FatalKind::None,
            watch_navigation: false,
            timeout,
        })
    }

    /// Sends a command (to a page session when `session` is given) and
    /// returns its id without waiting for the answer.
    pub fn send(
        &mut self,
        session: Option<&str>,
        method: &str,
        params: Value,
    ) -> Result<u64, BrowserError> {
        self.check_fatal()?;
        let id = self.next_id;
        self.next_id += 1;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if let Some(s) = session {
            msg["sessionId"] = Value::String(s.into());
        }
        self.ws
            .send(Message::Text(msg.to_string().into()))
            .map_err(|e| self.lost(e))?;
        Ok(id)
    }

    /// Waits for the answer to command `id` (named `method` in errors).
    pub fn wait(&mut self, id: u64, method: &str) -> Result<Value, BrowserError> {
        let deadline = Instant::now() + self.timeout;
        loop {
            if let Some(r) = self.responses.remove(&id) {
                return r.map_err(|e| BrowserError::protocol(method, e.0));
            }
            self.check_fatal()?;
            self.read_one(deadline, method)?;
        }
    }

    /// Sends a command and waits for its answer.
    pub fn call(
        &mut self,
        session: Option<&str>,
        method: &str,
        params: Value,
    ) -> Result<Value, BrowserError> {
        let id = self.send(session, method, params)?;
        self.wait(id, method)
    }

    /// Waits for the next kept event named `method`, removing it.
    pub fn wait_event(&mut self, method: &str) -> Result<Value, BrowserError> {
        let deadline = Instant::now() + self.timeout;
        loop {
            if let Some(i) = self.events.iter().position(|(m, _)| m == method) {
                return Ok(self.events.remove(i).map(|(_, p)| p).unwrap_or(Value::Null));
            }
            self.check_fatal()?;
            self.read_one(deadline, method)?;
        }
    }

    /// Removes and returns the answer to command `id` if it has arrived
    /// (read while waiting for something else).
    pub fn take_response(&mut self, id: u64) -> Option<Result<Value, RemoteError>> {
        self.responses.remove(&id)
    }

    /// Removes and returns a kept event named `method` if one has arrived.
    pub fn take_event(&mut self, method: &str) -> Option<Value> {
        let i = self.events.iter().position(|(m, _)| m == method)?;
        self.events.remove(i).map(|(_, p)| p)
    }

    /// The error of an event that ended the session, if any.
    pub fn check_fatal(&self) -> Result<(), BrowserError> {
        match (&self.fatal, self.fatal_kind) {
            (None, _) | (_, FatalKind::None) => Ok(()),
            (Some(m), FatalKind::Crash) => Err(BrowserError::Crashed(m.clone())),
            (Some(m), FatalKind::Navigation) => Err(BrowserError::NavigatedAway { url: m.clone() }),
            (Some(m), FatalKind::Disconnect) => Err(BrowserError::Disconnected(m.clone())),
        }
    }

    fn lost(&mut self, e: tungstenite::Error) -> BrowserError {
        let m = e.to_string();
        if self.fatal.is_none() {
            self.fatal = Some(m.clone());
            self.fatal_kind = FatalKind::Disconnect;
        }
        BrowserError::Disconnected(m)
    }

    /// Reads and routes one message.
    fn read_one(&mut self, deadline: Instant, waiting_for: &str) -> Result<(), BrowserError> {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(BrowserError::Timeout {
                method: waiting_for.into(),
                timeout_s: self.timeout.as_secs_f64(),
            });
        }
        let _ = self
            .ws
            .get_ref()
            .set_read_timeout(Some(left.max(Duration::from_millis(1))));
        let msg = match self.ws.read() {
            Ok(m) => m,
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                return Err(BrowserError::Timeout {
                    method: waiting_for.into(),
                    timeout_s: self.timeout.as_secs_f64(),
                })
            }
            Err(e) => return Err(self.lost(e)),
        };
        let text = match msg {
            Message::Text(t) => t,
            Message::Close(_) => {
                return Err(self.lost(tungstenite::Error::ConnectionClosed));
            }
            _ => return Ok(()),
        };
        let v: Value = serde_json::from_str(text.as_str()).map_err(|e| {
            BrowserError::protocol(waiting_for, format!("bad JSON from browser: {e}"))
        })?;
        if let Some(id) = v.get("id").and_then(Value::as_u64) {
            let r = match v.get("error") {
                Some(err) => Err(RemoteError(
                    err.get("message")
                        .and_then(Value::as_str)
                        .unwrap_or("unknown error")
                        .to_string(),
                )),
                None => Ok(v.get("result").cloned().unwrap_or(Value::Null)),
            };
            self.responses.insert(id, r);
            return Ok(());
        }
        let Some(method) = v.get("method").and_then(Value::as_str) else {
            return Ok(());
        };
        let params = v.get("params").cloned().unwrap_or(Value::Null);
        match method {
            "Inspector.targetCrashed" | "Target.targetCrashed" => {
                self.set_fatal(FatalKind::Crash, "renderer process died".into());
            }
            "Target.detachedFromTarget" => {
                self.set_fatal(
                    FatalKind::Crash,
                    "page closed (detached from target)".into(),
                );
            }
            "Page.frameNavigated" if self.watch_navigation => {
                let frame = &params["frame"];
                if frame.get("parentId").is_none() {
                    let url = format!(
                        "{}{}",
                        frame["url"].as_str().unwrap_or("?"),
                        frame["urlFragment"].as_str().unwrap_or("")
                    );
                    self.set_fatal(FatalKind::Navigation, url);
                }
            }
            "Page.javascriptDialogOpening" => {
                let m = params["message"].as_str().unwrap_or("").to_string();
                self.set_fatal(FatalKind::Crash, format!("page opened a dialog: {m:?}"));
            }
            m if KEPT_EVENTS.contains(&m) => self.events.push_back((m.to_string(), params)),
            _ => {}
        }
        Ok(())
    }

    fn set_fatal(&mut self, kind: FatalKind, m: String) {
        if self.fatal.is_none() {
            self.fatal = Some(m);
            self.fatal_kind = kind;
        }
    }

    /// Closes the connection politely (errors ignored: the browser is
    /// about to be killed anyway).
    pub fn close(&mut self) {
        let _ = self.ws.close(None);
        let _ = self.ws.flush();
    }
}
