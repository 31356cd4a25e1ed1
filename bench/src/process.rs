//! A solver in any language, run as a separate program that speaks JSON
//! lines over its standard input and output (`nprl-bench --solver-cmd
//! "python3 my_solver.py"`). It gets everything a built-in solver gets:
//! its own column in the tables, performance profiles (evaluations and
//! time) and data profiles.
//!
//! # The protocol
//!
//! One JSON object per line each way. The program starts by naming
//! itself:
//!
//! ```text
//! solver  -> {"solver": "py-lm"}
//! ```
//!
//! Then, for each instance, the runner sends the problem and answers the
//! program's requests until it says it is done:
//!
//! ```text
//! runner  -> {"problem": {"set": "mgh", "name": "01_rosenbrock", "scale": 1.0,
//!             "n": 2, "m": 2, "x0": [-1.2, 1.0], "max_evals": 6000}}
//! solver  -> {"residuals": [-1.2, 1.0]}
//! runner  -> {"residuals": [-4.4, 2.2]}
//! solver  -> {"jacobian": [-1.2, 1.0]}
//! runner  -> {"jacobian": [[24.0, 10.0], [-1.0, 0.0]]}        (m rows of n)
//! ...
//! solver  -> {"done": {"status": "converged", "converged": true}}
//! ```
//!
//! `done` may also name the stop in the workspace's vocabulary,
//! `"termination"`: one of `Converged`, `TargetReached`, `MaxIterations`,
//! `MaxEvaluations`, `TimeLimit`, `Stopped`, `Failed`
//! ([`solve::Termination`]); without it a converged run's is `Converged`.
//!
//! - A residual evaluation counts 1 against the run's budget, a Jacobian
//!   $n$. A refused or failed evaluation is answered `{"error": MESSAGE,
//!   "budget_spent": BOOL}`; once the budget is spent, the program should
//!   send `done` (the run is recorded as `budget`).
//! - The program may instead end a run with `{"failed": MESSAGE}` (recorded
//!   as `error: MESSAGE`). Either way the run's answer is the best point
//!   the program evaluated; it need not send it.
//! - Numbers that are not finite (an overflowing residual) are sent as
//!   `null`.
//! - After the last instance the runner closes the program's input; the
//!   program should then exit. A program that exits early, writes
//!   something else, or stays silent past the run's time limit plus
//!   [`GRACE`] gets that run recorded as an error and is started afresh
//!   for the next one.
//!
//! The command is split on whitespace (no shell, no quoting); for
//! anything more, point it at a script. `scripts/bench/client_lm.py` is a
//! complete client (a Levenberg-Marquardt in plain Python) that a test
//! runs.

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::error::{BenchError, Result};
use crate::open::{BenchSolver, Problem, Stop};

/// How long past a run's time limit the runner waits for the program
/// before it stops it.
pub const GRACE: Duration = Duration::from_secs(30);

/// How long the runner waits for a program's first line, its name.
const GREETING: Duration = Duration::from_secs(60);

/// A solver that is a program speaking the [protocol](self).
pub struct ProcessSolver {
    name: String,
    command: Vec<String>,
    session: Mutex<Option<Session>>,
}

/// One running program.
struct Session {
    child: Child,
    /// `None` once closed.
    input: Option<ChildStdin>,
    lines: Receiver<std::io::Result<String>>,
}

impl ProcessSolver {
    /// Starts `command` and reads its name.
    ///
    /// # Errors
    /// [`BenchError::Solver`] (naming the command) if it cannot be started,
    /// does not name itself on its first line within a minute, or names
    /// itself with an empty name.
    pub fn start(command: &str) -> Result<Self> {
        let words: Vec<String> = command.split_whitespace().map(str::to_string).collect();
        let refused = |reason: String| BenchError::Solver {
            solver: command.to_string(),
            problem: "(start)".into(),
            reason,
        };
        if words.is_empty() {
            return Err(refused("the command is empty".into()));
        }
        let (session, name) = Session::start(&words).map_err(&refused)?;
        Ok(Self {
            name,
            command: words,
            session: Mutex::new(Some(session)),
        })
    }

    /// The command, as started.
    pub fn command(&self) -> String {
        self.command.join(" ")
    }

    /// One run over the protocol; `Err` ends the session.
    fn converse(&self, session: &mut Session, problem: &Problem<'_>) -> std::result::Result<Stop, Ended> {
        let deadline = problem.deadline() + GRACE;
        session.send(&json!({"problem": {
            "set": problem.set(),
            "name": problem.name(),
            "scale": problem.scale(),
            "n": problem.n(),
            "m": problem.m(),
            "x0": problem.x0(),
            "max_evals": problem.max_evals(),
        }}))?;
        loop {
            let line = session.next_line(deadline).map_err(Ended::Broken)?;
            let request: Value = serde_json::from_str(&line)
                .map_err(|e| Ended::Broken(format!("not JSON ({e}): {}", store::shorten(&line))))?;
            if let Some(x) = request.get("residuals") {
                let x = point(x, problem.n())?;
                let mut r = vec![0.0; problem.m()];
                let reply = match problem.residuals(&x, &mut r) {
                    Ok(()) => json!({ "residuals": r }),
                    Err(e) => json!({"error": e.to_string(), "budget_spent": e.budget_spent()}),
                };
                session.send(&reply)?;
            } else if let Some(x) = request.get("jacobian") {
                let x = point(x, problem.n())?;
                let mut jac = vec![0.0; problem.m() * problem.n()];
                let reply = match problem.jacobian(&x, &mut jac) {
                    Ok(()) => json!({ "jacobian": jac.chunks(problem.n().max(1)).collect::<Vec<_>>() }),
                    Err(e) => json!({"error": e.to_string(), "budget_spent": e.budget_spent()}),
                };
                session.send(&reply)?;
            } else if let Some(done) = request.get("done") {
                let converged = done.get("converged").and_then(Value::as_bool).unwrap_or(false);
                // optional: one of solve::Termination's names
                let termination = done
                    .get("termination")
                    .and_then(|t| serde_json::from_value(t.clone()).ok())
                    .or(converged.then_some(solve::Termination::Converged));
                return Ok(Stop {
                    status: done.get("status").and_then(Value::as_str).unwrap_or("done").to_string(),
                    converged,
                    termination,
                });
            } else if let Some(message) = request.get("failed") {
                return Err(Ended::Failed(
                    message.as_str().map_or_else(|| message.to_string(), str::to_string),
                ));
            } else {
                return Err(Ended::Broken(format!(
                    "expected residuals, jacobian, done or failed, got {}",
                    store::shorten(&line)
                )));
            }
        }
    }
}

/// How a conversation ended other than by `done`.
enum Ended {
    /// The program said `failed`; it stays usable.
    Failed(String),
    /// The program broke the protocol, exited or fell silent; it is
    /// stopped.
    Broken(String),
}

impl From<String> for Ended {
    fn from(message: String) -> Self {
        Self::Broken(message)
    }
}

/// The point of a request: `n` numbers.
fn point(x: &Value, n: usize) -> std::result::Result<Vec<f64>, Ended> {
    let values: Option<Vec<f64>> = x.as_array().and_then(|a| a.iter().map(Value::as_f64).collect());
    match values {
        Some(v) if v.len() == n => Ok(v),
        _ => Err(Ended::Broken(format!(
            "a point must be a list of {n} numbers, got {}",
            store::shorten(&x.to_string())
        ))),
    }
}

impl Session {
    /// Starts the program and reads its name.
    fn start(words: &[String]) -> std::result::Result<(Self, String), String> {
        let mut session = Self::spawn(words)?;
        let line = match session.next_line(Instant::now() + GREETING) {
            Ok(line) => line,
            Err(e) => {
                session.stop();
                return Err(e);
            }
        };
        let name = serde_json::from_str::<Value>(&line)
            .ok()
            .and_then(|v| v.get("solver").and_then(Value::as_str).map(str::to_string))
            .filter(|n| !n.trim().is_empty());
        match name {
            Some(name) => Ok((session, name)),
            None => {
                session.stop();
                Err(format!(
                    "its first line must be {{\"solver\": \"NAME\"}}, got {}",
                    store::shorten(&line)
                ))
            }
        }
    }

    fn spawn(words: &[String]) -> std::result::Result<Self, String> {
        let mut child = Command::new(&words[0])
            .args(&words[1..])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("cannot start `{}`: {e}", words.join(" ")))?;
        let (Some(input), Some(output)) = (child.stdin.take(), child.stdout.take()) else {
            let _ = child.kill();
            return Err("no pipes to the program".into());
        };
        let (send, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(output).lines() {
                if send.send(line).is_err() {
                    break;
                }
            }
        });
        Ok(Self {
            child,
            input: Some(input),
            lines,
        })
    }

    fn send(&mut self, message: &Value) -> std::result::Result<(), String> {
        let input = self.input.as_mut().ok_or("the program's input is closed")?;
        writeln!(input, "{message}")
            .and_then(|()| input.flush())
            .map_err(|e| format!("cannot write to the program: {e}"))
    }

    /// The program's next line, by `deadline`.
    fn next_line(&mut self, deadline: Instant) -> std::result::Result<String, String> {
        let wait = deadline.saturating_duration_since(Instant::now());
        match self.lines.recv_timeout(wait) {
            Ok(Ok(line)) => Ok(line),
            Ok(Err(e)) => Err(format!("cannot read from the program: {e}")),
            Err(RecvTimeoutError::Timeout) => Err(format!("no answer within {:.0} s", wait.as_secs_f64())),
            Err(RecvTimeoutError::Disconnected) => {
                let status = self.child.wait().map_or_else(|e| e.to_string(), |s| s.to_string());
                Err(format!("the program exited ({status})"))
            }
        }
    }

    fn stop(mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl BenchSolver for ProcessSolver {
    fn name(&self) -> &str {
        &self.name
    }

    fn solve(&self, problem: &Problem<'_>) -> std::result::Result<Stop, String> {
        let mut slot = self.session.lock().map_err(|_| "a previous run panicked".to_string())?;
        let mut session = match slot.take() {
            Some(s) => s,
            // started afresh after a broken run: it names itself again
            None => match Session::start(&self.command)? {
                (session, name) if name == self.name => session,
                (session, name) => {
                    session.stop();
                    return Err(format!("restarted, it names itself `{name}`, not `{}`", self.name));
                }
            },
        };
        match self.converse(&mut session, problem) {
            Ok(stop) => {
                *slot = Some(session);
                Ok(stop)
            }
            Err(Ended::Failed(message)) => {
                *slot = Some(session);
                Err(message)
            }
            Err(Ended::Broken(message)) => {
                session.stop();
                Err(format!("{}: {message}", self.command()))
            }
        }
    }
}

impl Drop for ProcessSolver {
    fn drop(&mut self) {
        if let Ok(mut slot) = self.session.lock()
            && let Some(mut session) = slot.take()
        {
            // closing its input asks the program to exit; it gets a moment
            drop(session.input.take());
            let until = Instant::now() + Duration::from_secs(2);
            while Instant::now() < until {
                if session.child.try_wait().ok().flatten().is_some() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            session.stop();
        }
    }
}
