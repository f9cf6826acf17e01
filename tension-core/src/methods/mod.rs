//! The tension distribution methods behind one seam.
//!
//! Every method is one module of this folder with the same signature,
//!
//! ```text
//! pub fn solve<T: Real, const N: usize, const M: usize>(
//!     problem: &Problem<'_, T, N, M>,
//!     previous: &PreviousCycle<T, M>,
//!     work: &mut PolygonWork<T, N, M>,
//! ) -> Result<Solution<T, M>, Error>
//! ```
//!
//! plus `supports(n, m)` (the shapes it serves), `NULL_SPACE` (whether it
//! reads the null-space basis of the factorisation, or only the particular
//! solution) and `WARM_START` (whether it uses the previous cycle's result). The `methods!` table at the bottom of this file registers
//! each one once: its [`Method`] variant, its name in `docs/conventions.md`,
//! its wire number in the serial protocol and its module. Everything that
//! lists methods (the CLI's help, the protocol, the benchmarks, the tests)
//! iterates [`Method::ALL`], so adding a method is one new file here and one
//! line in that table.

use nalgebra::{SMatrix, SVector};

use crate::{
    linalg::WrenchFactorization,
    polygon::{ActivePair, VertexList, WalkHints},
    tension_polygon::TensionPolygon,
    Error, Real, Solution, TensionLimits,
};

/// One tension distribution problem: find `t` with `W t = f` and
/// `t_min <= t <= t_max`, with `W` already factored.
#[derive(Clone, Copy)]
pub struct Problem<'a, T: Real, const N: usize, const M: usize> {
    /// The wrench matrix `W` (`N x M`).
    pub w: &'a SMatrix<T, N, M>,
    /// The wrench the cables must balance, `f = -w_e`.
    pub f: &'a SVector<T, N>,
    /// The tension limits.
    pub limits: &'a TensionLimits<T, M>,
    /// `W^T = Q [R; 0]`, with the null-space columns when the method's
    /// `NULL_SPACE` asks for them.
    pub factorization: &'a WrenchFactorization<T, N, M>,
}

/// What a method may carry from the previous cycle's solution to warm-start
/// the next one (the barycenter's and the norms' active pair, the analytic
/// centre's tensions). A method ignores what it has no use for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreviousCycle<T: Real, const M: usize> {
    /// The previous cycle's most robust vertex of the feasible polygon.
    pub active_pair: Option<ActivePair>,
    /// The previous cycle's tensions.
    pub tensions: Option<SVector<T, M>>,
}

impl<T: Real, const M: usize> PreviousCycle<T, M> {
    /// No history: every method starts cold.
    pub const NONE: Self = Self { active_pair: None, tensions: None };

    /// Only an active pair (or none).
    pub const fn pair(active_pair: Option<ActivePair>) -> Self {
        Self { active_pair, tensions: None }
    }

    /// Only the previous tensions (or none).
    pub const fn tensions(tensions: Option<SVector<T, M>>) -> Self {
        Self { active_pair: None, tensions }
    }

    /// Remembers a successful solution (an absent active pair keeps the
    /// previous one).
    pub fn remember(&mut self, solution: &Solution<T, M>) {
        if let Some(pair) = solution.diagnostics.active_pair {
            self.active_pair = Some(pair);
        }
        self.tensions = Some(solution.tensions);
    }
}

impl<T: Real, const M: usize> Default for PreviousCycle<T, M> {
    fn default() -> Self {
        Self::NONE
    }
}

/// Room the polygon methods fill in place (`work` in the seam): the
/// feasible polygon and its vertex list, about 1 KB for 8 cables in `f32`
/// (2 KB in `f64`). Whatever it held is overwritten; a control loop keeps
/// one ([`Workspace`]) rather than clearing a new one every call. Methods
/// without a polygon ignore it; a one-off call ([`solve`]) starts with an
/// empty one ([`Self::lazy`]) that only a polygon method fills.
pub struct PolygonWork<T: Real, const N: usize, const M: usize> {
    room: Option<PolygonRoom<T, N, M>>,
    /// What the room's vertex list starts with when it is made here.
    hints: WalkHints<M>,
}

/// The polygon and its vertices, once made.
pub(crate) struct PolygonRoom<T: Real, const N: usize, const M: usize> {
    pub(crate) polygon: TensionPolygon<T, N, M>,
    pub(crate) vertices: VertexList<T, M>,
}

impl<T: Real, const N: usize, const M: usize> PolygonRoom<T, N, M> {
    fn new(hints: WalkHints<M>) -> Self {
        Self { polygon: TensionPolygon::zeroed(), vertices: VertexList::with_hints(hints) }
    }
}

impl<T: Real, const N: usize, const M: usize> PolygonWork<T, N, M> {
    /// With the room made (what a control loop keeps: no call ever makes
    /// it).
    pub fn new() -> Self {
        Self { room: Some(PolygonRoom::new(WalkHints::NONE)), hints: WalkHints::NONE }
    }

    /// Without it: the first polygon method to run makes it (the methods
    /// without a polygon, called once, clear nothing).
    pub fn lazy() -> Self {
        Self::lazy_hinted(WalkHints::NONE)
    }

    /// [`Self::lazy`], the room's walk to try `hints` (a solver's last
    /// walk's: [`Self::hints`]) when it is made.
    pub fn lazy_hinted(hints: WalkHints<M>) -> Self {
        Self { room: None, hints }
    }

    /// The last walk's successors, when a polygon method made the room.
    pub fn hints(&self) -> Option<WalkHints<M>> {
        self.room.as_ref().map(|room| room.vertices.hints())
    }

    /// The room, made if it was not.
    pub(crate) fn room(&mut self) -> &mut PolygonRoom<T, N, M> {
        let hints = self.hints;
        self.room.get_or_insert_with(|| PolygonRoom::new(hints))
    }
}

impl<T: Real, const N: usize, const M: usize> Default for PolygonWork<T, N, M> {
    fn default() -> Self {
        Self::new()
    }
}

/// What [`solve_with`] fills in place: the factorisation and the polygon
/// methods' room. A control loop keeps one for its calls.
pub struct Workspace<T: Real, const N: usize, const M: usize> {
    /// `W^T = Q [R; 0]` of the last call.
    pub factorization: WrenchFactorization<T, N, M>,
    /// The polygon methods' room.
    pub polygon: PolygonWork<T, N, M>,
}

impl<T: Real, const N: usize, const M: usize> Workspace<T, N, M> {
    /// Empty, with the polygon's room made ([`PolygonWork::new`]).
    pub fn new() -> Self {
        Self { factorization: WrenchFactorization::zeroed(), polygon: PolygonWork::new() }
    }

    /// Empty, the polygon's room made only if a polygon method runs
    /// ([`PolygonWork::lazy_hinted`], its walk trying `hints`): for a
    /// one-off call.
    pub(crate) fn lazy(hints: WalkHints<M>) -> Self {
        Self { factorization: WrenchFactorization::zeroed(), polygon: PolygonWork::lazy_hinted(hints) }
    }
}

impl<T: Real, const N: usize, const M: usize> Default for Workspace<T, N, M> {
    fn default() -> Self {
        Self::new()
    }
}

/// Shapes served by the methods that need the polygon (`r = 2`).
pub(crate) const fn redundancy_two(n: usize, m: usize) -> bool {
    n > 0 && m == n + 2
}

/// Shapes served by the methods for any redundancy (`M >= N`).
pub(crate) const fn any_redundancy(n: usize, m: usize) -> bool {
    n > 0 && m >= n
}

/// Solves `problem`'s `W t = f` within the limits with `method`, from `w`,
/// `f` and `limits`: factors `W` (with the null space only for methods that
/// read it) and calls the method's module. [`Error::UnsupportedShape`] for a
/// shape the method does not serve.
pub fn solve<T: Real, const N: usize, const M: usize>(
    method: Method,
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    previous: &PreviousCycle<T, M>,
) -> Result<Solution<T, M>, Error> {
    // Filled in place: no factorisation moved through a `Result`; the
    // polygon's room is made only if the method has a polygon.
    let mut workspace = Workspace::lazy(WalkHints::NONE);
    solve_with(method, &mut workspace, w, f, limits, previous)
}

/// [`solve`] with the factorisation and the polygon written to the
/// caller's `scratch` (whatever it held is overwritten): a control loop
/// that keeps one does not clear a new one (about 170 numbers for the
/// factorisation, 1 KB for the polygon with 8 cables) every cycle.
pub fn solve_with<T: Real, const N: usize, const M: usize>(
    method: Method,
    scratch: &mut Workspace<T, N, M>,
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    previous: &PreviousCycle<T, M>,
) -> Result<Solution<T, M>, Error> {
    if !method.supports(N, M) {
        return Err(Error::UnsupportedShape);
    }
    let Workspace { factorization, polygon: work } = scratch;
    factorization.factor(w, &[true; M], method.null_columns(N, M))?;
    solve_factored(method, factorization, work, w, f, limits, previous)
}

/// [`solve_with`] for a `W` the caller has factored already
/// ([`WrenchFactorization::factor`] with at least
/// [`Method::null_columns`] null-space columns), so that what else it
/// computes from `W` (a least-squares estimate through
/// [`WrenchFactorization::solve_gram`]) shares the factorisation: the
/// same result as [`solve_with`] when `factorization` is `w`'s.
/// [`Error::UnsupportedShape`] when the method does not serve the shape
/// or when `factorization` holds none or lacks the null-space columns the
/// method reads (after a failed factorisation, the caller has its error).
pub fn solve_factored<T: Real, const N: usize, const M: usize>(
    method: Method,
    factorization: &WrenchFactorization<T, N, M>,
    work: &mut PolygonWork<T, N, M>,
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    previous: &PreviousCycle<T, M>,
) -> Result<Solution<T, M>, Error> {
    let held = factorization.null_columns();
    if !method.supports(N, M) || held.is_none_or(|c| c < method.null_columns(N, M)) {
        return Err(Error::UnsupportedShape);
    }
    let problem = Problem { w, f, limits, factorization };
    let result = method.dispatch(&problem, previous, work);
    // A warm start may make a method faster, never make it fail: a failure
    // that is not a proof about the problem is tried again from cold.
    match result {
        Err(e) if method.warm_starts() && *previous != PreviousCycle::NONE && !e.is_certain() => {
            method.dispatch(&problem, &PreviousCycle::NONE, work)
        }
        result => result,
    }
}

/// The registry: one line per method, `Variant = wire number, "name", module;`.
/// Wire numbers are the serial protocol's method ids: never reuse or
/// renumber one (`tests::wire_numbers_are_pinned` holds them).
macro_rules! methods {
    ($( $(#[$doc:meta])* $variant:ident = $wire:literal, $name:literal, $module:ident; )*) => {
        $( pub mod $module; )*

        /// The tension distribution methods, named as in `docs/conventions.md`.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Method {
            $( $(#[$doc])* $variant, )*
        }

        impl Method {
            /// Every method, in the order of the registry.
            pub const ALL: [Method; [$(Method::$variant),*].len()] = [$(Method::$variant),*];

            /// The name (`docs/conventions.md`).
            pub const fn name(self) -> &'static str {
                match self { $( Method::$variant => $name, )* }
            }

            /// The method's number in the serial protocol (stable).
            pub const fn wire_id(self) -> u8 {
                match self { $( Method::$variant => $wire, )* }
            }

            /// The method with wire number `id`, if any.
            pub const fn from_wire_id(id: u8) -> Option<Self> {
                match id { $( $wire => Some(Method::$variant), )* _ => None }
            }

            /// Whether the method serves `n` degrees of freedom and `m` cables.
            pub const fn supports(self, n: usize, m: usize) -> bool {
                match self { $( Method::$variant => $module::supports(n, m), )* }
            }

            /// How many null-space columns the method reads from the
            /// factorisation of an `n x m` `W`: all `m - n` for a method
            /// that reads the null space, none for the others.
            pub const fn null_columns(self, n: usize, m: usize) -> usize {
                if self.reads_null_space() { m.saturating_sub(n) } else { 0 }
            }

            /// Whether the method starts from the previous cycle's solution.
            pub const fn warm_starts(self) -> bool {
                match self { $( Method::$variant => $module::WARM_START, )* }
            }

            /// Whether the method reads the factorisation's null-space basis.
            pub const fn reads_null_space(self) -> bool {
                match self { $( Method::$variant => $module::NULL_SPACE, )* }
            }

            /// The method on an already factored problem (the factorisation
            /// must hold the null space when [`Self::reads_null_space`]).
            pub fn solve_factored<T: Real, const N: usize, const M: usize>(
                self,
                problem: &Problem<'_, T, N, M>,
                previous: &PreviousCycle<T, M>,
            ) -> Result<Solution<T, M>, Error> {
                if !self.supports(N, M) {
                    return Err(Error::UnsupportedShape);
                }
                self.dispatch(problem, previous, &mut PolygonWork::lazy())
            }

            /// The method's module, for a shape already checked.
            fn dispatch<T: Real, const N: usize, const M: usize>(
                self,
                problem: &Problem<'_, T, N, M>,
                previous: &PreviousCycle<T, M>,
                work: &mut PolygonWork<T, N, M>,
            ) -> Result<Solution<T, M>, Error> {
                match self { $( Method::$variant => $module::solve(problem, previous, work), )* }
            }
        }
    };
}

methods! {
    /// `barycenter`: Lamaury & Gouttefarde 2013 (`M = N + 2`).
    Barycenter = 0, "barycenter", barycenter;
    /// `barycenter-brute`: Mikelsons et al. 2008 (`M = N + 2`).
    BarycenterBrute = 1, "barycenter-brute", barycenter_brute;
    /// `analytic-centre`: Di Paola et al. 2024 (any `M >= N`).
    AnalyticCentre = 2, "analytic-centre", analytic_centre;
    /// `closed-form`: Pott et al. 2009 (any `M >= N`).
    ClosedForm = 3, "closed-form", closed_form;
    /// `improved-closed-form`: Pott 2013 (any `M >= N`).
    ImprovedClosedForm = 4, "improved-closed-form", improved_closed_form;
    /// `puncture`: Müller, Reichert & Bruckmann 2014 (any `M >= N`).
    Puncture = 5, "puncture", puncture;
    /// `improved-puncture`: Müller, Reichert & Bruckmann 2014 (any `M >= N`).
    ImprovedPuncture = 6, "improved-puncture", improved_puncture;
    /// `min-2-norm`: smallest 2-norm (any `M >= N`).
    Min2Norm = 7, "min-2-norm", min_2_norm;
    /// `min-1-norm`: smallest 1-norm (any `M >= N`).
    Min1Norm = 8, "min-1-norm", min_1_norm;
    /// `optimally-safe`: Borgstrom et al. 2009 (any `M >= N`).
    OptimallySafe = 9, "optimally-safe", optimally_safe;
}

impl Method {
    /// Parses the name (`docs/conventions.md`).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_numbers_are_pinned() {
        // The serial protocol's method ids: a change here breaks every host
        // that selects a method on a board.
        let pinned = [
            ("barycenter", 0),
            ("barycenter-brute", 1),
            ("analytic-centre", 2),
            ("closed-form", 3),
            ("improved-closed-form", 4),
            ("puncture", 5),
            ("improved-puncture", 6),
            ("min-2-norm", 7),
            ("min-1-norm", 8),
            ("optimally-safe", 9),
        ];
        assert_eq!(Method::ALL.len(), pinned.len());
        for (name, id) in pinned {
            let m = Method::from_name(name).unwrap();
            assert_eq!(m.wire_id(), id, "{name}");
            assert_eq!(Method::from_wire_id(id), Some(m));
        }
        assert_eq!(Method::from_wire_id(10), None);
        assert_eq!(Method::from_wire_id(255), None);
    }

    #[test]
    fn names_round_trip_and_shapes() {
        for m in Method::ALL {
            assert_eq!(Method::from_name(m.name()), Some(m));
        }
        assert_eq!(Method::from_name("barycentre"), None);
        assert!(Method::Barycenter.supports(6, 8) && !Method::Barycenter.supports(6, 7));
        assert!(Method::ImprovedClosedForm.supports(6, 12) && !Method::ClosedForm.supports(6, 5));
        assert!(!Method::ClosedForm.supports(0, 3));
    }
}
