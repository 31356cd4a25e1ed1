//! Helper threads that form parts of the band normal equations, and
//! evaluate parts of the residuals, while the solver's own thread does the
//! first part ([`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel)).
//!
//! An iteration at 1000 time steps is short, and waking a parked thread
//! (rayon's or `std::thread`'s) costs a sizeable part of it, more so on
//! virtual machines: that ate most of the gain of the split (the
//! measurements are in the message of commit 9361b09). So the helpers live for the whole solve and, after each
//! part, spin for up to [`SPIN`] waiting for the next one before they
//! park: between two assemblies the solver only factorises and evaluates
//! residuals. The jobs own their buffers (copies of $\theta$ and $r$, the
//! helper's band matrix and vectors), which travel to the helper and back
//! through channels, so no memory is shared and nothing is allocated per
//! iteration.
//!
//! On a machine whose cores are busy a helper may wait for a core for a
//! whole scheduler time slice at every hand-over, which made a two-thread
//! solve 10-85 times slower than one thread. So every answer's wait is
//! timed against the work this thread did meanwhile: after [`LATE_LIMIT`]
//! answer(s) that came [late](is_late), [`Helpers::degraded`] says so and the
//! solver goes on with one thread ([`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel)).

use std::ops::Range;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::thread::Scope;
use std::time::{Duration, Instant};

use crate::error::{Result, TrajoptError};
use crate::gauss_newton::split::{self, SplitDone, SplitJob};
use crate::least_squares::{BandForm, BandNormalEquations, LeastSquaresProblem, Part, Point};
use crate::linalg::{BandLayout, BandedSym};

/// How long a helper (or the solver waiting for one) spins before it
/// parks: longer than the gap between two assemblies at the horizons
/// where the split pays, short enough not to hold a core for long after a
/// solve.
const SPIN: Duration = Duration::from_millis(2);

/// How many late answers make the helpers [degraded](Helpers::degraded).
const LATE_LIMIT: usize = 1;

/// Whether an answer that took `waited` after this thread had worked `own`
/// since sending the job was late: the parts are balanced, so a helper that
/// had its core answers within about `own`; one waiting for a core takes a
/// scheduler time slice (milliseconds) more.
fn is_late(own: Duration, waited: Duration) -> bool {
    waited > 2 * own + Duration::from_millis(1)
}

/// One part to form, with the buffers it is formed into.
struct PartJob {
    part: usize,
    parts: usize,
    theta: Vec<f64>,
    r: Vec<f64>,
    layout: Arc<BandLayout>,
    h: BandedSym,
    grad: Vec<f64>,
    /// The diagonal of $S$ when $S$ is asked for.
    diag: Option<Vec<f64>>,
    /// $S$ alone ([`BandForm::second_order_part`]) instead
    /// of the normal equations.
    s_only: bool,
}

/// Where [`Helpers::band_parts`] writes: the normal equations (with
/// `grad`) or $S$ alone (without).
pub(crate) struct PartsOut<'a> {
    h: &'a mut BandedSym,
    grad: Option<&'a mut [f64]>,
    second_order: Option<&'a mut [f64]>,
}

impl<'a> From<BandNormalEquations<'a>> for PartsOut<'a> {
    /// The normal equations.
    fn from(out: BandNormalEquations<'a>) -> Self {
        Self {
            h: out.h,
            grad: Some(out.grad),
            second_order: out.second_order_diagonal,
        }
    }
}

impl<'a> From<&'a mut BandedSym> for PartsOut<'a> {
    /// $S$ alone.
    fn from(s: &'a mut BandedSym) -> Self {
        Self {
            h: s,
            grad: None,
            second_order: None,
        }
    }
}

/// A formed part: the job (its buffers), the problem's answer, and the
/// first column of the part's band matrix that is not zero (the later
/// parts of a time-ordered problem leave the first columns zero: only the
/// rest needs to travel between the cores).
struct PartDone {
    job: PartJob,
    result: Result<bool>,
    first_column: usize,
}

/// Rows of the residuals to evaluate, with the buffers they go into.
struct ResidualJob {
    part: usize,
    parts: usize,
    theta: Vec<f64>,
    /// Full length; the part's rows are written.
    r: Vec<f64>,
}

enum Job {
    Band(PartJob),
    Residuals(ResidualJob),
    Split(SplitJob),
}

enum Done {
    /// The helper's thread has started.
    Ready,
    Band(PartDone),
    Residuals(ResidualJob, Result<Range<usize>>),
    Split(SplitDone),
}

/// A helper thread's end of the channels, and its buffers while idle.
struct Helper {
    jobs: Sender<Job>,
    done: Receiver<Done>,
    spare: Option<PartJob>,
    spare_residuals: Option<ResidualJob>,
    /// When the last job was sent.
    sent_at: Instant,
}

impl Helper {
    /// Sends `job`; false if the helper is gone.
    fn send(&mut self, job: Job) -> bool {
        self.sent_at = Instant::now();
        self.jobs.send(job).is_ok()
    }

    /// The answer to the last job, counting it in `late` if it came late
    /// ([`is_late`]); `None` if the helper is gone.
    fn answer(&self, late: &mut usize) -> Option<Done> {
        let asked = Instant::now();
        let mut done = receive(&self.done);
        if matches!(done, Some(Done::Ready)) {
            // its start, not yet seen by `Helpers::degraded`
            done = receive(&self.done);
        }
        if is_late(asked - self.sent_at, asked.elapsed()) {
            *late += 1;
        }
        done
    }
}

/// The helper threads of one solve; dropping it ends them.
pub(crate) struct Helpers {
    helpers: Vec<Helper>,
    /// Answers that came late ([`is_late`]).
    late: usize,
    /// Whether every helper has said it started ([`Done::Ready`]).
    ready: bool,
}

/// How long the solver waits for its helpers' threads to start before it
/// goes on without them (a thread starts in tens of microseconds on an
/// idle machine; on a busy one it may wait for a core for many
/// milliseconds, at the first hand-over).
const START: Duration = Duration::from_millis(1);

impl Helpers {
    /// Starts `count` helper threads in `scope`, each forming the parts of
    /// `problem` it is sent.
    pub(crate) fn spawn<'scope, 'env, P>(scope: &'scope Scope<'scope, 'env>, problem: &'env P, count: usize) -> Self
    where
        P: LeastSquaresProblem + Sync + ?Sized,
    {
        let helpers = (0..count)
            .map(|_| {
                let (jobs, job_rx) = channel::<Job>();
                let (done_tx, done) = channel::<Done>();
                scope.spawn(move || {
                    // looked up once: a problem without a band form has no
                    // jobs for its helpers (the solver sees them gone)
                    let Some(form) = problem.band_form() else {
                        return;
                    };
                    if done_tx.send(Done::Ready).is_err() {
                        return;
                    }
                    // the helper's part of a split system, kept between jobs
                    let mut split_part = None;
                    while let Some(job) = receive(&job_rx) {
                        let done = match job {
                            Job::Band(mut job) => {
                                let part = Part {
                                    index: job.part,
                                    count: job.parts,
                                };
                                let at = Point {
                                    theta: &job.theta,
                                    r: &job.r,
                                };
                                let result = if job.s_only {
                                    form.second_order_part(part, at, &job.layout, &mut job.h)
                                } else {
                                    let out = BandNormalEquations {
                                        h: &mut job.h,
                                        grad: &mut job.grad,
                                        second_order_diagonal: job.diag.as_deref_mut(),
                                    };
                                    form.normal_equations_part(part, at, &job.layout, out)
                                };
                                let first_column = job.h.first_nonzero_column();
                                Done::Band(PartDone {
                                    job,
                                    result,
                                    first_column,
                                })
                            }
                            Job::Split(job) => match split::run_job(&mut split_part, form, job) {
                                Some(done) => Done::Split(done),
                                // a job out of order: the solver sees the helper gone
                                None => break,
                            },
                            Job::Residuals(mut job) => {
                                let part = Part {
                                    index: job.part,
                                    count: job.parts,
                                };
                                let result = form.residuals_part(part, &job.theta, &mut job.r);
                                Done::Residuals(job, result)
                            }
                        };
                        if done_tx.send(done).is_err() {
                            break;
                        }
                    }
                });
                Helper {
                    jobs,
                    done,
                    spare: None,
                    spare_residuals: None,
                    sent_at: Instant::now(),
                }
            })
            .collect();
        Self {
            helpers,
            late: 0,
            ready: false,
        }
    }

    /// Whether the helpers are waiting for cores and one thread would be
    /// faster: a helper's thread did not start within [`START`] of the
    /// first call, or [`LATE_LIMIT`] answers came late.
    pub(crate) fn degraded(&mut self) -> bool {
        if !self.ready {
            let start = Instant::now();
            for helper in &self.helpers {
                loop {
                    match helper.done.try_recv() {
                        Ok(Done::Ready) => break,
                        Err(TryRecvError::Empty) if start.elapsed() < START => std::thread::yield_now(),
                        // not started in time, gone, or out of order: go on alone
                        _ => {
                            self.late = LATE_LIMIT;
                            break;
                        }
                    }
                }
            }
            self.ready = true;
        }
        self.late >= LATE_LIMIT
    }

    /// [`BandForm::normal_equations`](crate::BandForm::normal_equations)
    /// (`out` with `grad`) or
    /// [`BandForm::second_order_part`](crate::BandForm::second_order_part)
    /// ($S$ alone, `out` without; false unless every part has it), formed
    /// in parts, part 0 on this thread and one part on each helper, and
    /// summed in the part order (so the result depends on the number of
    /// parts, not on timing).
    pub(crate) fn band_parts(
        &mut self,
        form: &dyn BandForm,
        at: Point<'_>,
        layout: &Arc<BandLayout>,
        out: PartsOut<'_>,
    ) -> Result<bool> {
        let Point { theta, r } = at;
        let PartsOut {
            h,
            mut grad,
            mut second_order,
        } = out;
        let s_only = grad.is_none();
        let n_grad = grad.as_deref().map_or(0, <[f64]>::len);
        let parts = self.helpers.len() + 1;
        let want_s = second_order.is_some();
        let mut sent = 0;
        for (i, helper) in self.helpers.iter_mut().enumerate() {
            let mut job = helper.spare.take().unwrap_or_else(|| PartJob {
                part: 0,
                parts: 0,
                theta: Vec::new(),
                r: Vec::new(),
                layout: Arc::clone(layout),
                h: BandedSym::zeros(h.size(), h.half_bandwidth()),
                grad: Vec::new(),
                diag: None,
                s_only,
            });
            job.s_only = s_only;
            job.part = i + 1;
            job.parts = parts;
            copy_into(&mut job.theta, theta);
            copy_into(&mut job.r, r);
            job.layout = Arc::clone(layout);
            if (job.h.size(), job.h.half_bandwidth()) != (h.size(), h.half_bandwidth()) {
                job.h = BandedSym::zeros(h.size(), h.half_bandwidth());
            }
            job.grad.resize(n_grad, 0.0);
            job.diag = match (want_s, job.diag.take()) {
                (true, Some(mut d)) => {
                    d.resize(n_grad, 0.0);
                    Some(d)
                }
                (true, None) => Some(vec![0.0; n_grad]),
                (false, _) => None,
            };
            if !helper.send(Job::Band(job)) {
                break;
            }
            sent += 1;
        }
        let part = Part { index: 0, count: parts };
        let mine = match grad.as_deref_mut() {
            Some(g) => {
                let out = BandNormalEquations {
                    h: &mut *h,
                    grad: g,
                    second_order_diagonal: second_order.as_deref_mut(),
                };
                form.normal_equations_part(part, at, layout, out)
            }
            None => form.second_order_part(part, at, layout, h),
        };
        // collect every part sent, even after an error, so that no answer
        // is left in a channel for the next call
        let mut outcome = mine;
        let (mut any_s, mut all_s) = (matches!(outcome, Ok(true)), matches!(outcome, Ok(true)));
        let Self { helpers, late, .. } = self;
        for helper in &mut helpers[..sent] {
            let Some(Done::Band(done)) = helper.answer(late) else {
                outcome = Err(helper_lost());
                continue;
            };
            match (&outcome, done.result) {
                (Ok(_), Ok(with_s)) => {
                    any_s |= with_s;
                    all_s &= with_s;
                    h.add_from_column(&done.job.h, done.first_column);
                    for (g, p) in grad.iter_mut().flat_map(|g| g.iter_mut()).zip(&done.job.grad) {
                        *g += p;
                    }
                    if let (Some(diag), Some(part)) = (second_order.as_deref_mut(), &done.job.diag) {
                        for (d, p) in diag.iter_mut().zip(part) {
                            *d += p;
                        }
                    }
                }
                (Ok(_), Err(e)) => outcome = Err(e),
                (Err(_), _) => {}
            }
            helper.spare = Some(done.job);
        }
        if sent < self.helpers.len() {
            outcome = Err(helper_lost());
        }
        outcome?;
        if let (Some(grad), true) = (grad, any_s && !all_s) {
            // S is missing in some part: J^T J alone, everywhere
            let out = PartsOut {
                h,
                grad: Some(grad),
                second_order: None,
            };
            return self.band_parts(form, at, layout, out);
        }
        Ok(all_s)
    }
}

impl Helpers {
    /// How many helper threads there are.
    pub(crate) fn count(&self) -> usize {
        self.helpers.len()
    }

    /// Sends a job to the first helper's split part; false if it is gone.
    fn split_send(&mut self, job: SplitJob) -> bool {
        self.helpers.first_mut().is_some_and(|h| h.send(Job::Split(job)))
    }

    /// Sends `job` to the first helper's split part, runs `mine` on this
    /// thread meanwhile, and returns its result with the helper's answer
    /// (`None` if the helper is gone).
    pub(crate) fn split_alongside<R>(&mut self, job: SplitJob, mine: impl FnOnce() -> R) -> (R, Option<SplitDone>) {
        let sent = self.split_send(job);
        let mine = mine();
        (mine, sent.then(|| self.split_receive()).flatten())
    }

    /// The first helper's answer to its split job; `None` if it is gone.
    fn split_receive(&mut self) -> Option<SplitDone> {
        let Self { helpers, late, .. } = self;
        match helpers.first()?.answer(late)? {
            Done::Split(done) => Some(done),
            _ => None,
        }
    }
}

impl Helpers {
    /// [`LeastSquaresProblem::residuals`] evaluated in parts, part 0 on this
    /// thread and one part on each helper.
    ///
    /// # Errors
    /// The problem's errors, or [`TrajoptError::InvalidParameter`] if the
    /// parts' rows do not cover every residual exactly once.
    pub(crate) fn residuals(&mut self, form: &dyn BandForm, theta: &[f64], r: &mut [f64]) -> Result<()> {
        let parts = self.helpers.len() + 1;
        let mut sent = 0;
        for (i, helper) in self.helpers.iter_mut().enumerate() {
            let mut job = helper.spare_residuals.take().unwrap_or(ResidualJob {
                part: 0,
                parts: 0,
                theta: Vec::new(),
                r: Vec::new(),
            });
            job.part = i + 1;
            job.parts = parts;
            copy_into(&mut job.theta, theta);
            job.r.resize(r.len(), 0.0);
            if !helper.send(Job::Residuals(job)) {
                break;
            }
            sent += 1;
        }
        let part = Part { index: 0, count: parts };
        let mine = form.residuals_part(part, theta, r);
        let mut outcome = mine.map(|range| vec![range]);
        let Self { helpers, late, .. } = self;
        for helper in &mut helpers[..sent] {
            let Some(Done::Residuals(job, result)) = helper.answer(late) else {
                outcome = Err(helper_lost());
                continue;
            };
            if let Ok(ranges) = &mut outcome {
                match result {
                    Ok(range) if range.end <= r.len() => {
                        r[range.clone()].copy_from_slice(&job.r[range.clone()]);
                        ranges.push(range);
                    }
                    Ok(_) => outcome = Err(uncovered(r.len())),
                    Err(e) => outcome = Err(e),
                }
            }
            helper.spare_residuals = Some(job);
        }
        if sent < self.helpers.len() {
            outcome = Err(helper_lost());
        }
        // every row written exactly once
        let mut ranges = outcome?;
        ranges.retain(|range| !range.is_empty());
        ranges.sort_by_key(|range| range.start);
        let mut next = 0;
        for range in &ranges {
            if range.start != next {
                return Err(uncovered(r.len()));
            }
            next = range.end;
        }
        if next != r.len() {
            return Err(uncovered(r.len()));
        }
        Ok(())
    }
}

fn uncovered(n: usize) -> TrajoptError {
    TrajoptError::InvalidParameter {
        name: "residual parts",
        reason: format!("their rows do not cover the {n} residuals exactly once"),
    }
}

fn copy_into(dst: &mut Vec<f64>, src: &[f64]) {
    dst.clear();
    dst.extend_from_slice(src);
}

fn helper_lost() -> TrajoptError {
    TrajoptError::InvalidParameter {
        name: "helper thread",
        reason: "it stopped (the problem panicked on it)".into(),
    }
}

/// The next message, spinning for up to [`SPIN`] before blocking; `None`
/// once the other end is gone.
fn receive<T>(rx: &Receiver<T>) -> Option<T> {
    let start = Instant::now();
    let mut spins = 0u32;
    loop {
        match rx.try_recv() {
            Ok(v) => return Some(v),
            Err(TryRecvError::Disconnected) => return None,
            Err(TryRecvError::Empty) => {}
        }
        // a yield, not a pure spin: on a busy core it lets the thread this
        // one waits for run (on an idle machine it returns at once)
        std::thread::yield_now();
        spins += 1;
        if spins.is_multiple_of(64) && start.elapsed() > SPIN {
            return rx.recv().ok();
        }
    }
}
