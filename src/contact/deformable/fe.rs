//! The 2-D linear-elastic finite element of the gear bodies: the 9-node
//! Lagrange quadrilateral (Q9), isoparametric, in plane strain, integrated
//! with 3 × 3 Gauss points; and the assembled, factorised stiffness of a mesh
//! of them.
//!
//! Plane strain, because the face (30 mm in the example) is many tooth
//! thicknesses wide, as the potential-energy compliance of
//! [`crate::contact::stiffness`] assumes (E' = E/(1 − ν²) there):
//!
//! σ = D ε, D = [[λ + 2μ, λ, 0], [λ, λ + 2μ, 0], [0, 0, μ]],
//! λ = E ν / ((1 + ν)(1 − 2ν)), μ = E / (2(1 + ν))
//! (Zienkiewicz & Taylor, *The Finite Element Method*, vol. 1, 6th ed., §6.2).
//!
//! The Q9 shape functions are products of the 1-D quadratic Lagrange
//! polynomials through ξ = −1, 0, 1; the local node a = 3 j + i sits at
//! (ξ_i, η_j). A quadratic element bends without shear locking at the
//! aspect ratios of a graded flank mesh, and full 3 × 3 integration keeps it
//! free of spurious modes. The stiffness acts on a body of unit thickness:
//! forces are per unit thickness \[N/m\].

use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use thiserror::Error;

/// A point or vector of the plane \[m\].
pub type Point = [f64; 2];

/// Why a finite-element model could not be built or solved.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FeError {
    /// An element's mapping folds over or degenerates: det J must be positive
    /// at every Gauss point.
    #[error("element {element}: Jacobian determinant {det:e} at a Gauss point; it must be positive")]
    DegenerateElement {
        /// Index of the element.
        element: usize,
        /// The offending determinant \[m²\].
        det: f64,
    },
    /// The material constants: E must be positive and ν in (−1, 0.5).
    #[error(
        "material: E = {youngs_modulus:e} Pa and ν = {poisson_ratio}; E must be positive, ν in (-1, 0.5)"
    )]
    Material {
        /// Young's modulus \[Pa\].
        youngs_modulus: f64,
        /// Poisson's ratio [-].
        poisson_ratio: f64,
    },
    /// The sparse Cholesky factorisation failed (the stiffness is not
    /// positive definite: the mesh is not held against rigid-body motion).
    #[error("stiffness factorisation: {0}; the mesh must be held against rigid-body motion")]
    Factorisation(String),
}

/// Isotropic linear elasticity in plane strain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneStrain {
    /// Lamé's first parameter λ \[Pa\].
    pub lambda: f64,
    /// Shear modulus μ \[Pa\].
    pub mu: f64,
}

impl PlaneStrain {
    /// The constants from Young's modulus `e` \[Pa\] and Poisson's ratio `nu` [-].
    pub fn new(e: f64, nu: f64) -> Result<Self, FeError> {
        if !(e > 0.0 && e.is_finite() && nu > -1.0 && nu < 0.5) {
            return Err(FeError::Material { youngs_modulus: e, poisson_ratio: nu });
        }
        Ok(Self { lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), mu: e / (2.0 * (1.0 + nu)) })
    }

    /// Stress (σ_xx, σ_yy, τ_xy) \[Pa\] of the strain (ε_xx, ε_yy, γ_xy) [-].
    pub fn stress(&self, strain: [f64; 3]) -> [f64; 3] {
        let (l, m) = (self.lambda, self.mu);
        [(l + 2.0 * m) * strain[0] + l * strain[1], l * strain[0] + (l + 2.0 * m) * strain[1], m * strain[2]]
    }
}

/// The 3-point Gauss rule on [−1, 1]: abscissae and weights.
pub const GAUSS3: [(f64, f64); 3] =
    [(-0.774_596_669_241_483_4, 5.0 / 9.0), (0.0, 8.0 / 9.0), (0.774_596_669_241_483_4, 5.0 / 9.0)];

/// The 1-D quadratic Lagrange polynomials through −1, 0, 1 at `s` and their
/// derivatives.
pub fn lagrange3(s: f64) -> ([f64; 3], [f64; 3]) {
    ([0.5 * s * (s - 1.0), 1.0 - s * s, 0.5 * s * (s + 1.0)], [s - 0.5, -2.0 * s, s + 0.5])
}

/// The Q9 shape functions at (ξ, η) and their derivatives by ξ and by η.
pub fn shape(xi: f64, eta: f64) -> ([f64; 9], [f64; 9], [f64; 9]) {
    let (lx, dx) = lagrange3(xi);
    let (ly, dy) = lagrange3(eta);
    let mut n = [0.0; 9];
    let mut n_xi = [0.0; 9];
    let mut n_eta = [0.0; 9];
    for j in 0..3 {
        for i in 0..3 {
            n[3 * j + i] = lx[i] * ly[j];
            n_xi[3 * j + i] = dx[i] * ly[j];
            n_eta[3 * j + i] = lx[i] * dy[j];
        }
    }
    (n, n_xi, n_eta)
}

/// The shape functions' derivatives by x and y at (ξ, η) of an element
/// with nodes `x` \[m\], and det J \[m²\].
fn gradients(x: &[Point; 9], xi: f64, eta: f64) -> ([f64; 9], [f64; 9], f64) {
    let (_, n_xi, n_eta) = shape(xi, eta);
    let mut j = [[0.0; 2]; 2];
    for a in 0..9 {
        j[0][0] += n_xi[a] * x[a][0];
        j[0][1] += n_xi[a] * x[a][1];
        j[1][0] += n_eta[a] * x[a][0];
        j[1][1] += n_eta[a] * x[a][1];
    }
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    let mut gx = [0.0; 9];
    let mut gy = [0.0; 9];
    for a in 0..9 {
        gx[a] = (j[1][1] * n_xi[a] - j[0][1] * n_eta[a]) / det;
        gy[a] = (-j[1][0] * n_xi[a] + j[0][0] * n_eta[a]) / det;
    }
    (gx, gy, det)
}

/// The 18 × 18 stiffness \[N/m\] of one Q9 element of unit thickness, the
/// degrees of freedom ordered (u_x, u_y) node by node; `Err` with the
/// determinant when the mapping is not positive at a Gauss point.
pub fn element_stiffness(x: &[Point; 9], m: &PlaneStrain) -> Result<[[f64; 18]; 18], f64> {
    let mut k = [[0.0; 18]; 18];
    let (l2m, l, mu) = (m.lambda + 2.0 * m.mu, m.lambda, m.mu);
    for (xi, wx) in GAUSS3 {
        for (eta, wy) in GAUSS3 {
            let (gx, gy, det) = gradients(x, xi, eta);
            if det.is_nan() || det <= 0.0 {
                return Err(det);
            }
            let w = wx * wy * det;
            for a in 0..9 {
                for b in 0..9 {
                    // Bᵀ D B for the node pair (a, b), written out.
                    let (ax, ay, bx, by) = (gx[a], gy[a], gx[b], gy[b]);
                    k[2 * a][2 * b] += w * (l2m * ax * bx + mu * ay * by);
                    k[2 * a][2 * b + 1] += w * (l * ax * by + mu * ay * bx);
                    k[2 * a + 1][2 * b] += w * (l * ay * bx + mu * ax * by);
                    k[2 * a + 1][2 * b + 1] += w * (l2m * ay * by + mu * ax * bx);
                }
            }
        }
    }
    Ok(k)
}

/// Strain (ε_xx, ε_yy, γ_xy) [-] at (ξ, η) of an element with nodes `x` \[m\]
/// and nodal displacements `u` \[m\], and det J \[m²\] there.
pub fn strain(x: &[Point; 9], u: &[Point; 9], xi: f64, eta: f64) -> ([f64; 3], f64) {
    let (gx, gy, det) = gradients(x, xi, eta);
    let mut e = [0.0; 3];
    for a in 0..9 {
        e[0] += gx[a] * u[a][0];
        e[1] += gy[a] * u[a][1];
        e[2] += gy[a] * u[a][0] + gx[a] * u[a][1];
    }
    (e, det)
}

/// Strain energy ∫ ½ σ·ε dA of one element of unit thickness \[J/m\], from
/// the strains and stresses at its Gauss points (independent of the
/// assembled stiffness).
pub fn element_energy(x: &[Point; 9], u: &[Point; 9], m: &PlaneStrain) -> f64 {
    let mut energy = 0.0;
    for (xi, wx) in GAUSS3 {
        for (eta, wy) in GAUSS3 {
            let (e, det) = strain(x, u, xi, eta);
            let s = m.stress(e);
            energy += 0.5 * wx * wy * det * (s[0] * e[0] + s[1] * e[1] + s[2] * e[2]);
        }
    }
    energy
}

/// Local coordinates (ξ, η) of the point `p` \[m\] in an element with nodes
/// `x` \[m\], by Newton's method from the centre; `None` when the point lies
/// outside the element (beyond a small tolerance) or Newton does not settle.
pub fn locate(x: &[Point; 9], p: Point) -> Option<(f64, f64)> {
    let (mut xi, mut eta) = (0.0, 0.0);
    for _ in 0..30 {
        let (n, n_xi, n_eta) = shape(xi, eta);
        let mut r = [-p[0], -p[1]];
        let mut j = [[0.0; 2]; 2];
        for a in 0..9 {
            r[0] += n[a] * x[a][0];
            r[1] += n[a] * x[a][1];
            j[0][0] += n_xi[a] * x[a][0];
            j[0][1] += n_eta[a] * x[a][0];
            j[1][0] += n_xi[a] * x[a][1];
            j[1][1] += n_eta[a] * x[a][1];
        }
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if det.abs() < f64::MIN_POSITIVE {
            return None;
        }
        let d_xi = (j[1][1] * r[0] - j[0][1] * r[1]) / det;
        let d_eta = (-j[1][0] * r[0] + j[0][0] * r[1]) / det;
        // Keep the iterate near the element: the quadratic map is only
        // invertible close to it.
        xi = (xi - d_xi).clamp(-2.0, 2.0);
        eta = (eta - d_eta).clamp(-2.0, 2.0);
        // Newton settles quadratically to round-off, ~1e-14 in ξ for a
        // point given to 1e-18 m in an element of 1e-4 m.
        if d_xi.abs() + d_eta.abs() < 1e-11 {
            let tol = 1e-9;
            return (xi.abs() <= 1.0 + tol && eta.abs() <= 1.0 + tol).then_some((xi, eta));
        }
    }
    None
}

/// A mesh of Q9 elements with the nodes held fixed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeMesh {
    /// Node coordinates \[m\].
    pub nodes: Vec<Point>,
    /// The nine nodes of each element, local node 3 j + i at (ξ_i, η_j).
    pub elements: Vec<[usize; 9]>,
    /// Whether each node is held (both displacement components zero).
    pub fixed: Vec<bool>,
}

impl FeMesh {
    /// The node coordinates of element `e` \[m\].
    pub fn element_nodes(&self, e: usize) -> [Point; 9] {
        self.elements[e].map(|n| self.nodes[n])
    }
}

/// A mesh's stiffness, assembled over the free degrees of freedom and
/// factorised once (sparse Cholesky, LLᵀ).
#[derive(Debug)]
pub struct FeSystem {
    /// Index of each node's (x, y) degree of freedom among the free ones.
    dof: Vec<[Option<usize>; 2]>,
    free: usize,
    llt: faer::sparse::linalg::solvers::Llt<usize, f64>,
}

impl FeSystem {
    /// Assembles and factorises the stiffness of `mesh` \[N/m per m of thickness\].
    pub fn new(mesh: &FeMesh, material: &PlaneStrain) -> Result<Self, FeError> {
        let mut dof = vec![[None, None]; mesh.nodes.len()];
        let mut free = 0;
        for (n, d) in dof.iter_mut().enumerate() {
            if !mesh.fixed[n] {
                *d = [Some(free), Some(free + 1)];
                free += 2;
            }
        }
        let mut triplets = Vec::with_capacity(mesh.elements.len() * 324 / 2);
        for (e, nodes) in mesh.elements.iter().enumerate() {
            let k = element_stiffness(&mesh.element_nodes(e), material)
                .map_err(|det| FeError::DegenerateElement { element: e, det })?;
            let map: Vec<Option<usize>> = nodes.iter().flat_map(|n| dof[*n]).collect();
            for (a, row) in map.iter().enumerate() {
                for (b, col) in map.iter().enumerate() {
                    // The lower triangle only: the factorisation reads that side.
                    if let (Some(r), Some(c)) = (row, col) {
                        if r >= c {
                            triplets.push(Triplet::new(*r, *c, k[a][b]));
                        }
                    }
                }
            }
        }
        let matrix = SparseColMat::<usize, f64>::try_new_from_triplets(free, free, &triplets)
            .map_err(|e| FeError::Factorisation(format!("{e:?}")))?;
        let llt = matrix.sp_cholesky(Side::Lower).map_err(|e| FeError::Factorisation(format!("{e:?}")))?;
        Ok(Self { dof, free, llt })
    }

    /// Number of free degrees of freedom.
    pub fn free_dofs(&self) -> usize {
        self.free
    }

    /// Solves for several load cases at once. Each case is a list of nodal
    /// forces (node, \[f_x, f_y\] \[N/m\]); forces on held nodes are taken by the
    /// support. Returns the free displacements, one column per case \[m\].
    pub fn solve(&self, cases: &[Vec<(usize, Point)>]) -> Mat<f64> {
        let mut rhs = Mat::<f64>::zeros(self.free, cases.len());
        for (c, loads) in cases.iter().enumerate() {
            for (node, f) in loads {
                for (k, d) in self.dof[*node].iter().enumerate() {
                    if let Some(i) = d {
                        rhs[(*i, c)] += f[k];
                    }
                }
            }
        }
        self.llt.solve_in_place(rhs.as_mut());
        rhs
    }

    /// Displacement \[m\] of `node` in load case `case` of a solution.
    pub fn displacement(&self, solution: &Mat<f64>, case: usize, node: usize) -> Point {
        self.dof[node].map(|d| d.map_or(0.0, |i| solution[(i, case)]))
    }

    /// The displacements of all nodes of an element in one load case \[m\].
    pub fn element_displacements(
        &self,
        mesh: &FeMesh,
        solution: &Mat<f64>,
        case: usize,
        e: usize,
    ) -> [Point; 9] {
        mesh.elements[e].map(|n| self.displacement(solution, case, n))
    }
}

/// Displacement \[m\] at local point (ξ, η) of an element with nodal
/// displacements `u` \[m\].
pub fn interpolate_displacement(u: &[Point; 9], xi: f64, eta: f64) -> Point {
    let (n, _, _) = shape(xi, eta);
    let mut out = [0.0; 2];
    for a in 0..9 {
        out[0] += n[a] * u[a][0];
        out[1] += n[a] * u[a][1];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2 × 2 patch of distorted, curved-edge Q9 elements on [0, 2]²: the
    /// grid point (i, j) of a 5 × 5 node grid, moved inside.
    fn patch() -> (Vec<Point>, Vec<[usize; 9]>) {
        let mut nodes = Vec::new();
        for j in 0..5 {
            for i in 0..5 {
                let (x, y) = (i as f64 * 0.5, j as f64 * 0.5);
                let interior = i % 4 != 0 && j % 4 != 0;
                let (dx, dy) =
                    if interior { (0.11 * (x * y).sin(), -0.07 * (x + 2.0 * y).cos()) } else { (0.0, 0.0) };
                nodes.push([x + dx, y + dy]);
            }
        }
        let mut elements = Vec::new();
        for ej in 0..2 {
            for ei in 0..2 {
                let mut e = [0; 9];
                for b in 0..3 {
                    for a in 0..3 {
                        e[3 * b + a] = (2 * ej + b) * 5 + 2 * ei + a;
                    }
                }
                elements.push(e);
            }
        }
        (nodes, elements)
    }

    #[test]
    fn patch_test_reproduces_a_constant_strain_exactly() {
        // Boundary nodes take a linear displacement field; the interior nodes
        // must follow it to round-off (Zienkiewicz & Taylor §10.3), and the
        // strain at every Gauss point must be the field's.
        let (nodes, elements) = patch();
        let m = PlaneStrain::new(210e9, 0.3).unwrap();
        let field = |p: Point| [1e-3 * p[0] + 2e-4 * p[1] + 1e-5, -3e-4 * p[0] + 5e-4 * p[1] - 2e-5];
        let n = nodes.len();
        let mut k = nalgebra::DMatrix::<f64>::zeros(2 * n, 2 * n);
        for e in &elements {
            let ke = element_stiffness(&e.map(|a| nodes[a]), &m).unwrap();
            for a in 0..18 {
                for b in 0..18 {
                    k[(2 * e[a / 2] + a % 2, 2 * e[b / 2] + b % 2)] += ke[a][b];
                }
            }
        }
        let boundary: Vec<bool> = (0..n).map(|i| (i % 5) % 4 == 0 || (i / 5) % 4 == 0).collect();
        let free: Vec<usize> = (0..2 * n).filter(|d| !boundary[d / 2]).collect();
        let held: Vec<usize> = (0..2 * n).filter(|d| boundary[d / 2]).collect();
        let u_held =
            nalgebra::DVector::from_iterator(held.len(), held.iter().map(|d| field(nodes[d / 2])[d % 2]));
        let k_ff = k.select_rows(&free).select_columns(&free);
        let k_fh = k.select_rows(&free).select_columns(&held);
        let u_free = k_ff.lu().solve(&(-(k_fh * u_held))).unwrap();
        for (i, d) in free.iter().enumerate() {
            let exact = field(nodes[d / 2])[d % 2];
            assert!((u_free[i] - exact).abs() < 1e-14, "dof {d}: {} vs {exact}", u_free[i]);
        }
        let mut u_all = vec![[0.0; 2]; n];
        for (a, p) in nodes.iter().enumerate() {
            u_all[a] = field(*p);
        }
        for e in &elements {
            let (s, _) = strain(&e.map(|a| nodes[a]), &e.map(|a| u_all[a]), 0.3, -0.6);
            for (got, want) in s.iter().zip([1e-3, 5e-4, 2e-4 - 3e-4]) {
                assert!((got - want).abs() < 1e-14, "strain {got} vs {want}");
            }
        }
    }

    #[test]
    fn locate_inverts_the_element_map() {
        let (nodes, elements) = patch();
        let x = elements[3].map(|a| nodes[a]);
        let (n, _, _) = shape(0.37, -0.81);
        let mut p = [0.0; 2];
        for a in 0..9 {
            p[0] += n[a] * x[a][0];
            p[1] += n[a] * x[a][1];
        }
        let (xi, eta) = locate(&x, p).unwrap();
        assert!((xi - 0.37).abs() < 1e-12 && (eta + 0.81).abs() < 1e-12);
        assert!(locate(&x, [-1.0, -1.0]).is_none());
    }
}
