//! Bounded-time linear algebra on fixed-size matrices.
//!
//! The wrench matrix is factored by Householder reflections applied to its
//! transpose, `W^T = Q [R; 0]` with `Q` orthogonal (`M x M`) and `R` upper
//! triangular (`N x N`): a fixed number of operations, no iteration, no
//! sorting, so nothing can loop or panic on NaN (inputs are checked for
//! finiteness anyway). From it:
//! * the minimum-norm solution of `W t = f` (`t = W^+ f`, Lamaury & Gouttefarde
//!   2013, Eq. 2): `R^T y = f`, `t = Q_1 y`;
//! * an orthonormal basis of the null space of `W`: the last `M - N` columns
//!   of `Q` (the `N` in their Eq. 2, the kernel of Di Paola et al. 2024, Eq. 6).

use nalgebra::{SMatrix, SVector};

use crate::{
    scalar::{all_finite, finite, greater},
    tolerance, Error, Real,
};

/// `W^T = Q [R; 0]`, computed once per pose and shared by every method.
///
/// `Q = H_1 ... H_N` is kept as its Householder reflections
/// `H_k = I - beta_k v_k v_k^T`, never formed: the null-space basis (the last
/// `M - N` columns of `Q`) and the minimum-norm solutions are obtained by
/// applying the reflections to vectors, about a quarter of the work of
/// accumulating `Q`. `R` is kept strictly above the diagonal of the reduced
/// `W^T` with its diagonal apart. The factorisation can be refilled in place
/// ([`Self::factor`]), so a control loop moves no large struct.
#[derive(Debug, Clone)]
pub struct WrenchFactorization<T: Real, const N: usize, const M: usize> {
    /// `W^T` reduced: `R` strictly above the diagonal (the rest is scratch).
    qr: SMatrix<T, M, N>,
    /// Householder vectors `v_k` in column `k`, zero above row `k`.
    v: SMatrix<T, M, N>,
    /// `2 / |v_k|^2`, zero for a skipped (already zero) column.
    beta: SVector<T, N>,
    /// Diagonal of `R`.
    rdiag: SVector<T, N>,
    /// Null-space basis in columns `0..M - N` (only the first
    /// [`Self::factor`]'s `null_columns` of them are filled).
    z: SMatrix<T, M, M>,
    /// How many columns of `z` the last [`Self::factor`] filled (`None`
    /// until one succeeds, and after one fails).
    null_filled: Option<usize>,
}

impl<T: Real, const N: usize, const M: usize> WrenchFactorization<T, N, M> {
    /// Factors `w` (`N x M`). Errors: [`Error::UnsupportedShape`] when
    /// `N > M` or `N == 0`, [`Error::NonFinite`], [`Error::Singular`] when the
    /// rank is below `N` (a diagonal entry of `R` below
    /// `16 M eps max|R_kk|`).
    pub fn new(w: &SMatrix<T, N, M>) -> Result<Self, Error> {
        Self::with_columns(w, &[true; M])
    }

    /// Factors `w` with only the columns marked `true` (the others are taken
    /// as zero): the reduced problem of the improved closed form, where fixed
    /// cables leave the system (Pott 2013, Eq. 4).
    pub fn with_columns(w: &SMatrix<T, N, M>, keep: &[bool; M]) -> Result<Self, Error> {
        let mut fact = Self::zeroed();
        fact.factor(w, keep, M.saturating_sub(N))?;
        Ok(fact)
    }

    /// An all-zero factorisation to be filled by [`Self::factor`].
    pub fn zeroed() -> Self {
        Self {
            qr: SMatrix::zeros(),
            v: SMatrix::zeros(),
            beta: SVector::zeros(),
            rdiag: SVector::zeros(),
            z: SMatrix::zeros(),
            null_filled: None,
        }
    }

    /// Refills `self` with the factorisation of `w` restricted to the columns
    /// marked in `keep` (see [`Self::with_columns`]), and the first
    /// `null_columns` (at most `M - N`) null-space columns. Same errors as
    /// [`Self::with_columns`]; on error `self` holds no valid factorisation.
    pub fn factor(
        &mut self,
        w: &SMatrix<T, N, M>,
        keep: &[bool; M],
        null_columns: usize,
    ) -> Result<(), Error> {
        self.null_filled = None;
        if N == 0 || N > M {
            return Err(Error::UnsupportedShape);
        }
        // a = W^T with dropped cables zeroed (M x N). The kept entries are
        // not checked for finiteness here: a NaN or an infinity among them
        // reaches what the factorisation keeps (a column's `norm2`, `R`, its
        // diagonal or `beta`: a non-finite entry of a later column makes
        // that column's dot product with every reflection, hence all of it,
        // non-finite), which is checked below. A dropped cable's entries
        // never enter the arithmetic, so they are checked here.
        // Written in place (`transpose_to`), not through a transposed copy
        // moved in: the board's factorisation 2 357 -> 2 290 instructions.
        w.transpose_to(&mut self.qr);
        for (i, &k) in keep.iter().enumerate() {
            if !k {
                if !all_finite(self.qr.row(i).iter().copied()) {
                    return Err(Error::NonFinite);
                }
                self.qr.row_mut(i).fill(T::zero());
            }
        }
        // Column-major: column j is `[T; M]`. Every inner loop runs over
        // whole columns of the constant length M (the Householder vectors
        // are zero above their first entry, which leaves the rows above
        // untouched exactly, and the zeros add nothing to the sums), so
        // the compiler unrolls them, with no bounds to check.
        let a_cols: &mut [[T; M]; N] = &mut self.qr.data.0;
        let v_cols: &mut [[T; M]; N] = &mut self.v.data.0;
        let mut rmax = T::zero();
        for (k, vk) in v_cols.iter_mut().enumerate() {
            let (done, later) = a_cols.split_at_mut(k + 1);
            let col = &done[k];
            // Householder vector for a[k.., k].
            let mut norm2 = T::zero();
            for i in 0..M {
                let c = if i >= k { col[i] } else { T::zero() };
                vk[i] = c;
                norm2 += c * c;
            }
            let norm = norm2.sqrt_native();
            let akk = col[k];
            self.beta[k] = T::zero();
            self.rdiag[k] = akk;
            if norm == T::zero() {
                vk.fill(T::zero()); // rank deficiency, caught below
                continue;
            }
            let alpha = if akk >= T::zero() { -norm } else { norm };
            let v0 = akk - alpha;
            let vnorm2 = norm2 - akk * akk + v0 * v0;
            if vnorm2 == T::zero() || !vnorm2.is_finite() {
                vk.fill(T::zero());
                if vnorm2 == T::zero() {
                    continue;
                }
                return Err(Error::NonFinite);
            }
            vk[k] = v0;
            self.rdiag[k] = alpha;
            let b = T::lit(2.0) / vnorm2;
            self.beta[k] = b;
            let vk = &*vk;
            // a <- H a on columns k + 1.., two at a time (as the null
            // space's columns below).
            let mut pairs = later.chunks_exact_mut(2);
            for pair in pairs.by_ref() {
                let (ci, cj) = pair.split_at_mut(1);
                reflect_pair(vk, b, &mut ci[0], &mut cj[0]);
            }
            for cj in pairs.into_remainder() {
                reflect(vk, b, cj);
            }
            let d = alpha.abs();
            if d > rmax {
                rmax = d;
            }
        }
        // What is kept: `R` (strictly above the diagonal of `qr`, the
        // rest of it is scratch), its diagonal and the reflections' `beta`
        // (their vectors come from columns already checked through `norm2`).
        let r_finite = self
            .qr
            .as_slice()
            .chunks_exact(M)
            .enumerate()
            .fold(true, |ok, (j, column)| ok & finite(&column[..j]));
        if !(r_finite && finite(self.rdiag.as_slice()) && finite(self.beta.as_slice())) {
            return Err(Error::NonFinite);
        }
        // Null-space basis: Z e_k = H_1 ... H_N e_{N+k}, two columns at a
        // time: each reflection is read once for both, one loop's
        // bookkeeping for two columns (the board's factorisation 2 571 ->
        // 2 492 instructions with eight cables), the same arithmetic per
        // column as one at a time.
        let r = null_columns.min(M - N);
        let mut k = 0;
        while k + 1 < r {
            let mut e = [T::zero(); M];
            let mut e2 = [T::zero(); M];
            e[N + k] = T::one();
            e2[N + k + 1] = T::one();
            self.apply_q_pair(&mut e, &mut e2);
            self.z.set_column(k, &SVector::from(e));
            self.z.set_column(k + 1, &SVector::from(e2));
            k += 2;
        }
        if k < r {
            let mut e: SVector<T, M> = SVector::zeros();
            e[N + k] = T::one();
            self.apply_q(&mut e);
            self.z.set_column(k, &e);
        }
        if !finite(&self.z.as_slice()[..r * M]) {
            return Err(Error::NonFinite);
        }
        let threshold = tolerance::rank(M, rmax);
        for i in 0..N {
            if self.rdiag[i].abs() <= threshold {
                return Err(Error::Singular);
            }
        }
        self.null_filled = Some(r);
        Ok(())
    }

    /// How many null-space columns the factorisation holds (what
    /// [`Self::factor`] was asked for); `None` when it holds none (before
    /// the first [`Self::factor`], or after one failed).
    pub fn null_columns(&self) -> Option<usize> {
        self.null_filled
    }

    /// `x <- Q x = H_1 (H_2 (... H_N x))`.
    fn apply_q(&self, x: &mut SVector<T, M>) {
        let (x_s, v_s) = (x.as_mut_slice(), self.v.as_slice());
        for k in (0..N).rev() {
            reflect(&v_s[k * M..(k + 1) * M], self.beta[k], x_s);
        }
    }

    /// [`Self::apply_q`] on `x` and `y` together: per reflection the same
    /// operations, in the same order, on each.
    fn apply_q_pair(&self, x: &mut [T; M], y: &mut [T; M]) {
        let v_s = self.v.as_slice();
        for k in (0..N).rev() {
            reflect_pair(&v_s[k * M..(k + 1) * M], self.beta[k], x, y);
        }
    }

    /// Entry `(i, j)` of `R`, `i <= j`.
    #[cfg(test)]
    fn r(&self, i: usize, j: usize) -> T {
        if i == j {
            self.rdiag[i]
        } else {
            self.qr[(i, j)]
        }
    }

    /// Minimum-norm solution of `W t = f` (the pseudo-inverse `W^+ f`).
    pub fn min_norm_solution(&self, f: &SVector<T, N>) -> SVector<T, M> {
        // Forward substitution R^T y = f, then t = Q [y; 0].
        let mut t: SVector<T, M> = SVector::zeros();
        for (i, column) in self.qr.as_slice().chunks_exact(M).enumerate() {
            // Column i of `qr` holds R_ki above the diagonal.
            let mut s = f[i];
            for (&r, &tk) in column.iter().zip(t.iter()).take(i) {
                s -= r * tk;
            }
            t[i] = s / self.rdiag[i];
        }
        self.apply_q(&mut t);
        t
    }

    /// `x` with `W W^T x = g` from `W W^T = R^T R` (`R^T y = g`, then
    /// `R x = y`): the normal equations of a least-squares problem in `W^T`
    /// without forming the Gram matrix (Björck's semi-normal equations,
    /// *Numerical Methods for Least Squares Problems*, 1996, Sect. 2.4.4).
    /// `None` when a pivot of the Gram matrix's `L D L^T`, `d_j = R_jj^2`,
    /// is not above `min_pivot` or not above `min_relative_pivot` times
    /// the diagonal entry `(W W^T)_jj = sum_(k <= j) R_kj^2` (the test a
    /// factorisation of `W W^T` itself would make), or when `x` is not
    /// finite.
    pub fn solve_gram(
        &self,
        g: &SVector<T, N>,
        min_pivot: T,
        min_relative_pivot: T,
    ) -> Option<SVector<T, N>> {
        let qr = self.qr.as_slice();
        // Column j of `qr` holds R_kj (k < j) in its first j entries.
        let r = |k: usize, j: usize| if k == j { self.rdiag[j] } else { qr[j * M + k] };
        let mut y: SVector<T, N> = SVector::zeros();
        for j in 0..N {
            let d = self.rdiag[j] * self.rdiag[j];
            let mut a = d;
            let mut s = g[j];
            for k in 0..j {
                let rkj = r(k, j);
                a += rkj * rkj;
                s -= rkj * y[k];
            }
            if !(d > min_pivot && d > min_relative_pivot * a) {
                return None;
            }
            y[j] = s / self.rdiag[j];
        }
        for jj in 0..N {
            let j = N - 1 - jj;
            let mut s = y[j];
            for k in (j + 1)..N {
                s -= r(j, k) * y[k];
            }
            y[j] = s / self.rdiag[j];
        }
        all_finite(y.iter().copied()).then_some(y)
    }

    /// Entry `(cable, k)` of the orthonormal null-space basis, `k < M - N`.
    #[inline]
    pub fn null(&self, cable: usize, k: usize) -> T {
        self.z[(cable, k)]
    }

    /// The degree of redundancy `r = M - N`.
    pub const fn redundancy(&self) -> usize {
        M - N
    }
}

/// `x <- H x` for the reflection `H = I - beta v v^T`: `x - (beta v . x) v`.
#[inline(always)]
fn reflect<T: Real>(v: &[T], beta: T, x: &mut [T]) {
    let s = dot(v, x) * beta;
    for (c, &vi) in x.iter_mut().zip(v) {
        *c -= s * vi;
    }
}

/// [`reflect`] on `x` and `y` together (each reflection's vector read
/// once for both): per column the same operations in the same order.
#[inline(always)]
fn reflect_pair<T: Real>(v: &[T], beta: T, x: &mut [T], y: &mut [T]) {
    let (sx, sy) = (dot(v, x) * beta, dot(v, y) * beta);
    for ((a, b), &vi) in x.iter_mut().zip(y.iter_mut()).zip(v) {
        *a -= sx * vi;
        *b -= sy * vi;
    }
}

/// `sum a_i b_i` over the shorter of the two slices.
///
/// On the board (an in-order FPU with a multiply-accumulate instruction)
/// one running sum, one `vmla` a term. On a host four sums of every fourth
/// term, added pairwise at the end: the same terms in another order, which
/// the compiler keeps in vector registers (a single running sum must be
/// added one term at a time, each addition waiting for the one before).
#[inline]
fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    #[cfg(target_os = "none")]
    {
        a.iter().zip(b).fold(T::zero(), |s, (&x, &y)| s + x * y)
    }
    #[cfg(not(target_os = "none"))]
    {
        let n = a.len().min(b.len());
        let (a, b) = (&a[..n], &b[..n]);
        let mut sums = [T::zero(); 4];
        let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
        let tail = a4.remainder().iter().zip(b4.remainder()).fold(T::zero(), |s, (&x, &y)| s + x * y);
        for (qa, qb) in a4.zip(b4) {
            for i in 0..4 {
                sums[i] += qa[i] * qb[i];
            }
        }
        ((sums[0] + sums[2]) + (sums[1] + sums[3])) + tail
    }
}

/// Solves `a x = b` for a symmetric positive definite matrix stored in the
/// leading `k x k` block of `a` (Cholesky, in place, bounded `k^3/6` steps).
/// [`Error::NoConvergence`] is not possible; a non-positive pivot gives
/// [`Error::Singular`]. Only the leading `k` entries of `b` are used and
/// overwritten with the solution.
pub fn cholesky_solve_leading<T: Real, const M: usize>(
    a: &mut SMatrix<T, M, M>,
    b: &mut SVector<T, M>,
    k: usize,
) -> Result<(), Error> {
    let k = k.min(M);
    for j in 0..k {
        let mut d = a[(j, j)];
        for p in 0..j {
            d -= a[(j, p)] * a[(j, p)];
        }
        if !greater(d, T::zero()) || !d.is_finite() {
            return Err(Error::Singular);
        }
        let d = d.sqrt_native();
        a[(j, j)] = d;
        for i in (j + 1)..k {
            let mut s = a[(i, j)];
            for p in 0..j {
                s -= a[(i, p)] * a[(j, p)];
            }
            a[(i, j)] = s / d;
        }
    }
    for i in 0..k {
        let mut s = b[i];
        for p in 0..i {
            s -= a[(i, p)] * b[p];
        }
        b[i] = s / a[(i, i)];
    }
    for i in (0..k).rev() {
        let mut s = b[i];
        for p in (i + 1)..k {
            s -= a[(p, i)] * b[p];
        }
        b[i] = s / a[(i, i)];
    }
    if all_finite(b.iter().take(k).copied()) {
        Ok(())
    } else {
        Err(Error::NonFinite)
    }
}

/// `A = L D L^T` of a small symmetric positive definite matrix (only the
/// lower triangle of `A` is read): `L` unit lower triangular, `D` diagonal,
/// no square roots, `N^3 / 6` multiply-adds, a fixed number of steps (no
/// pivoting, no iteration), so nothing loops or panics on NaN. Used for the
/// normal equations of the forward kinematics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ldl<T: Real, const N: usize> {
    /// `L` strictly below the diagonal, `D` on it.
    factor: SMatrix<T, N, N>,
}

impl<T: Real, const N: usize> Ldl<T, N> {
    /// Factors `a`. [`Error::Singular`] when a pivot `d_j` is not above
    /// `16 N eps a_jj` (a zero, negative or NaN pivot included): the rounding
    /// of the elimination is a few `N eps a_jj`, so a smaller pivot is noise.
    /// On success also returns `max_j a_jj / d_j`: with `A = J^T J` this is
    /// `1 / min_j sin^2(phi_j)`, `phi_j` the angle between column `j` of `J`
    /// and the span of the columns before it, the inverse squared smallest
    /// diagonal entry of the Cholesky factor of `J` with unit columns, and a
    /// lower bound on that matrix's squared condition number.
    pub fn factor(a: &SMatrix<T, N, N>) -> Result<(Self, T), Error> {
        let mut f = *a;
        let mut ratio = T::one();
        let floor = T::lit(16.0) * T::lit(N as f64) * T::eps();
        for j in 0..N {
            let mut d = a[(j, j)];
            for p in 0..j {
                d -= f[(j, p)] * f[(j, p)] * f[(p, p)];
            }
            if !greater(d, floor * a[(j, j)]) || !d.is_finite() {
                return Err(Error::Singular);
            }
            f[(j, j)] = d;
            let q = a[(j, j)] / d;
            if q > ratio {
                ratio = q;
            }
            for i in (j + 1)..N {
                let mut s = a[(i, j)];
                for p in 0..j {
                    s -= f[(i, p)] * f[(j, p)] * f[(p, p)];
                }
                f[(i, j)] = s / d;
            }
        }
        Ok((Self { factor: f }, ratio))
    }

    /// Solves `A x = b` (forward substitution, diagonal, back substitution:
    /// `N^2` multiply-adds and `N` divisions).
    pub fn solve(&self, b: &SVector<T, N>) -> SVector<T, N> {
        let f = &self.factor;
        let mut x = *b;
        for i in 0..N {
            let mut s = x[i];
            for p in 0..i {
                s -= f[(i, p)] * x[p];
            }
            x[i] = s;
        }
        for i in 0..N {
            x[i] /= f[(i, i)];
        }
        for i in (0..N).rev() {
            let mut s = x[i];
            for p in (i + 1)..N {
                s -= f[(p, i)] * x[p];
            }
            x[i] = s;
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> SMatrix<f64, 3, 5> {
        SMatrix::<f64, 3, 5>::from_fn(|i, j| (((i * 5 + j) * (i * 5 + j) + 1) as f64).sin())
    }

    /// The null-space columns, made two at a time (`apply_q_pair`) with
    /// one left over when their count is odd, are each `Q e_(N+k)` from
    /// `apply_q` alone, bit for bit, in both precisions.
    #[test]
    fn null_columns_in_pairs_are_q_applied_one_by_one() {
        fn check<T: Real, const N: usize, const M: usize>(w: &SMatrix<T, N, M>) -> usize {
            let mut compared = 0;
            for r in 0..=(M - N) {
                let mut fact = WrenchFactorization::<T, N, M>::zeroed();
                fact.factor(w, &[true; M], r).unwrap();
                assert_eq!(fact.null_columns(), Some(r));
                for k in 0..r {
                    let mut e: SVector<T, M> = SVector::zeros();
                    e[N + k] = T::one();
                    fact.apply_q(&mut e);
                    for i in 0..M {
                        let (a, b) = (fact.null(i, k), e[i]);
                        let same = a == b && a.is_sign_negative() == b.is_sign_negative();
                        assert!(same, "r {r}, column {k}, row {i}");
                    }
                    compared += 1;
                }
            }
            compared
        }
        let w3 = SMatrix::<f64, 3, 6>::from_fn(|i, j| (((i * 6 + j) * (i * 6 + j) + 1) as f64).sin());
        let w2 = SMatrix::<f64, 2, 6>::from_fn(|i, j| (((i * 7 + j) * 3 + 2) as f64).cos());
        // Three null columns (a pair and one alone), four (two pairs).
        let compared = check(&w3) + check(&w3.map(|x| x as f32)) + check(&w2) + check(&w2.map(|x| x as f32));
        assert_eq!(compared, 2 * (1 + 2 + 3) + 2 * (1 + 2 + 3 + 4));
    }

    /// The factorisation's update of the later columns two at a time is the
    /// update one column at a time (this reference: the loop before the
    /// pairs), bit for bit: `R`, its diagonal, the reflections and their
    /// `beta`, for shapes whose later columns come in pairs, with one left
    /// over, or both, in both precisions.
    #[test]
    fn later_columns_in_pairs_are_reflected_one_by_one() {
        fn same<T: Real>(a: T, b: T) -> bool {
            a == b && a.is_sign_negative() == b.is_sign_negative()
        }
        // The reference is written with indices, as the algorithm is
        // printed (Golub & Van Loan, Alg. 5.2.1).
        #[allow(clippy::needless_range_loop)]
        fn check<T: Real, const N: usize, const M: usize>(w: &SMatrix<T, N, M>) -> usize {
            let mut fact = WrenchFactorization::<T, N, M>::zeroed();
            fact.factor(w, &[true; M], M - N).unwrap();
            // One column at a time.
            let mut a: [[T; M]; N] = w.transpose().data.0;
            let mut compared = 0;
            for k in 0..N {
                let mut v = [T::zero(); M];
                let mut norm2 = T::zero();
                for i in k..M {
                    v[i] = a[k][i];
                    norm2 += v[i] * v[i];
                }
                let (norm, akk) = (norm2.sqrt_native(), a[k][k]);
                let alpha = if akk >= T::zero() { -norm } else { norm };
                let v0 = akk - alpha;
                v[k] = v0;
                let b = T::lit(2.0) / (norm2 - akk * akk + v0 * v0);
                assert!(same(fact.rdiag[k], alpha) && same(fact.beta[k], b), "column {k}");
                for i in 0..M {
                    assert!(same(fact.v[(i, k)], v[i]), "column {k}, row {i}");
                }
                for j in k + 1..N {
                    let s = dot(&v, &a[j]) * b;
                    for i in 0..M {
                        a[j][i] -= s * v[i];
                    }
                    for i in 0..=k {
                        assert!(same(fact.qr[(i, j)], a[j][i]), "R ({i}, {j})");
                        compared += 1;
                    }
                }
            }
            compared
        }
        let w68 = SMatrix::<f64, 6, 8>::from_fn(|i, j| (((i * 8 + j) * (i * 8 + j) + 1) as f64).sin());
        let w35 = SMatrix::<f64, 3, 5>::from_fn(|i, j| (((i * 5 + j) * (i * 5 + j) + 2) as f64).cos());
        let w47 = SMatrix::<f64, 4, 7>::from_fn(|i, j| (((i * 7 + j) * (i * 7 + j) + 3) as f64).sin());
        // R's entries above the diagonal (15, 3 and 6 per matrix), each
        // compared after every reflection from its row's on: 35, 4 and 10.
        let compared =
            check(&w68) + check(&w68.map(|x| x as f32)) + check(&w35) + check(&w35.map(|x| x as f32));
        let compared = compared + check(&w47) + check(&w47.map(|x| x as f32));
        assert_eq!(compared, 2 * (35 + 4 + 10));
    }

    #[test]
    fn q_is_orthogonal_and_the_null_columns_annihilate_w() {
        let w = sample();
        let fact = WrenchFactorization::new(&w).unwrap();
        let z = fact.z.fixed_columns::<2>(0);
        assert!((z.transpose() * z - SMatrix::<f64, 2, 2>::identity()).amax() < 1e-14);
        assert!((w * z).amax() < 1e-14);
        // Q is orthogonal: it keeps norms; R^T R = W W^T.
        let mut x = SVector::<f64, 5>::new(1.0, 2.0, 3.0, 4.0, 5.0);
        let norm = x.norm();
        fact.apply_q(&mut x);
        assert!((x.norm() - norm).abs() < 1e-14);
        let r = SMatrix::<f64, 3, 3>::from_fn(|i, j| if i <= j { fact.r(i, j) } else { 0.0 });
        assert!((r.transpose() * r - w * w.transpose()).amax() < 1e-13);
    }

    #[test]
    fn min_norm_solution_is_orthogonal_to_the_null_space() {
        let w = sample();
        let fact = WrenchFactorization::new(&w).unwrap();
        let f = SVector::<f64, 3>::new(1.0, -2.0, 0.5);
        let t = fact.min_norm_solution(&f);
        assert!((w * t - f).amax() < 1e-13);
        for k in 0..2 {
            let z = SVector::<f64, 5>::from_fn(|i, _| fact.null(i, k));
            assert!(z.dot(&t).abs() < 1e-13);
        }
    }

    #[test]
    fn dropped_columns_get_zero_and_rank_loss_is_singular() {
        let w = sample();
        let keep = [true, false, true, true, true];
        let fact = WrenchFactorization::with_columns(&w, &keep).unwrap();
        let f = SVector::<f64, 3>::new(1.0, 2.0, 3.0);
        let t = fact.min_norm_solution(&f);
        assert!(t[1].abs() < 1e-13);
        assert!((w * t - f).amax() < 1e-12);
        let mut rank2 = w;
        let r0 = rank2.row(0).into_owned();
        rank2.set_row(2, &(r0 * 2.0));
        assert_eq!(WrenchFactorization::new(&rank2).unwrap_err(), Error::Singular);
        let mut nan = w;
        nan[(1, 1)] = f64::NAN;
        assert_eq!(WrenchFactorization::new(&nan).unwrap_err(), Error::NonFinite);
    }

    /// The factorisation checks what it keeps, not its input: one NaN or
    /// infinity anywhere in `W` (kept or dropped cable, any row) must still
    /// give `NonFinite`, never a factorisation, in both precisions and with
    /// and without the null-space columns. Counts the cases that reached
    /// their assert.
    #[test]
    fn one_non_finite_entry_anywhere_is_refused() {
        fn run<T: Real>() -> usize {
            let w6 =
                SMatrix::<T, 6, 8>::from_fn(|i, j| T::lit((((i * 8 + j) * (i * 8 + j) + 1) as f64).sin()));
            assert!(WrenchFactorization::new(&w6).is_ok());
            let bad = [
                T::zero() / T::zero(),
                T::max_value().unwrap() * T::lit(4.0),
                -(T::max_value().unwrap() * T::lit(4.0)),
            ];
            let mut checked = 0;
            for i in 0..6 {
                for j in 0..8 {
                    for &x in &bad {
                        for keep_j in [true, false] {
                            for null_columns in [0, 2] {
                                let mut w = w6;
                                w[(i, j)] = x;
                                let mut keep = [true; 8];
                                keep[j] = keep_j;
                                let mut fact = WrenchFactorization::<T, 6, 8>::zeroed();
                                assert_eq!(
                                    fact.factor(&w, &keep, null_columns),
                                    Err(Error::NonFinite),
                                    "entry ({i}, {j}) = {x:?}, kept {keep_j}"
                                );
                                checked += 1;
                            }
                        }
                    }
                }
            }
            checked
        }
        assert_eq!(run::<f64>() + run::<f32>(), 2 * 6 * 8 * 3 * 2 * 2);
    }

    #[test]
    fn cholesky_on_the_leading_block() {
        let mut a = SMatrix::<f64, 4, 4>::from_fn(|i, j| if i == j { 4.0 } else { 1.0 });
        a[(3, 3)] = f64::NAN; // outside the 3 x 3 block: never read
        let mut b = SVector::<f64, 4>::new(6.0, 6.0, 6.0, f64::NAN);
        cholesky_solve_leading(&mut a, &mut b, 3).unwrap();
        for i in 0..3 {
            assert!((b[i] - 1.0).abs() < 1e-14);
        }
        let mut indefinite = SMatrix::<f64, 2, 2>::new(1.0, 2.0, 2.0, 1.0);
        let mut rhs = SVector::<f64, 2>::new(1.0, 1.0);
        assert_eq!(cholesky_solve_leading(&mut indefinite, &mut rhs, 2).unwrap_err(), Error::Singular);
    }

    #[test]
    fn ldl_solves_and_refuses_singular_and_nan() {
        let a = SMatrix::<f64, 3, 3>::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0);
        let b = SVector::<f64, 3>::new(1.0, -2.0, 0.5);
        let (f, ratio) = Ldl::factor(&a).unwrap();
        let x = f.solve(&b);
        assert!((a * x - b).amax() < 1e-14);
        assert!((1.0..2.0).contains(&ratio));
        let singular = SMatrix::<f64, 2, 2>::new(1.0, 2.0, 2.0, 4.0);
        assert_eq!(Ldl::factor(&singular).unwrap_err(), Error::Singular);
        let indefinite = SMatrix::<f64, 2, 2>::new(1.0, 2.0, 2.0, 1.0);
        assert_eq!(Ldl::factor(&indefinite).unwrap_err(), Error::Singular);
        let zero_column = SMatrix::<f64, 2, 2>::new(1.0, 0.0, 0.0, 0.0);
        assert_eq!(Ldl::factor(&zero_column).unwrap_err(), Error::Singular);
        let nan = SMatrix::<f64, 2, 2>::new(1.0, f64::NAN, f64::NAN, 1.0);
        assert_eq!(Ldl::factor(&nan).unwrap_err(), Error::Singular);
        let inf = SMatrix::<f32, 2, 2>::new(f32::INFINITY, 0.0, 0.0, 1.0);
        assert_eq!(Ldl::factor(&inf).unwrap_err(), Error::Singular);
    }
}
