"""What a wall_mode Jacobian says (fluid-server/examples/wall_mode.rs writes it):

  python3 modes.py J.bin [J.bin ...]

For each: the eigenvalues of J (the rates linearised about rest), how many grow
(Re λ > 1e-6 max|λ|) and the ten largest Re λ; the fastest mode's vector (inverse
iteration) and its share of the energy of small motions, E = Σ m (c² ρ'²/ρ0² + |u|²)/2,
by distance inside the outer fluid layer; and how far W J is from skew-symmetric
(|WJ + (WJ)ᵀ| / |WJ|, whole and by the same layers), W the energy weights of J.bin.txt.
J conserves E exactly when W J is skew."""
import sys
import time
import numpy as np

for path in sys.argv[1:]:
    n = int(np.fromfile(path, '<u8', 1)[0])
    J = np.fromfile(path, '<f8', offset=8).reshape(n, n)
    side = np.loadtxt(path + '.txt')
    pos, w = side[:, :3], side[:, 3:].reshape(-1)
    depth = np.round(np.minimum(pos - pos.min(0), pos.max(0) - pos).min(1), 9)
    layers = np.unique(depth)
    t0 = time.time()
    lam = np.linalg.eigvals(J)
    order = np.argsort(-lam.real)
    grow = (lam.real > 1e-6 * np.abs(lam).max()).sum()
    print(f"{path}: {n // 4} fluid particles, J {n} × {n} (eigenvalues in {time.time() - t0:.0f} s)")
    print(f"  growing: {grow} of {n}; largest Re λ {lam.real[order[0]]:.4g} 1/s; |Im λ| up to {np.abs(lam.imag).max():.4g} 1/s")
    print("  ten largest:", ", ".join(f"{lam[k].real:.4g}{lam[k].imag:+.3g}i" for k in order[:10]))
    if grow:
        mu = lam[order[0]]
        v = np.random.default_rng(1).standard_normal(n).astype(complex)
        A = J - (mu + 1e-6 * abs(mu)) * np.eye(n)
        for _ in range(3):
            v = np.linalg.solve(A, v)
            v /= np.linalg.norm(v)
        e = (w * np.abs(v) ** 2).reshape(-1, 4).sum(1)
        print("  fastest mode's energy by depth inside the outer fluid layer:",
              ", ".join(f"{d:.3f} m {e[depth == d].sum() / e.sum():.3f}" for d in layers))
    S = w[:, None] * J
    A = S + S.T
    rows_a = np.sqrt((A.reshape(n // 4, 4, n) ** 2).sum((1, 2)))
    rows_s = np.sqrt((S.reshape(n // 4, 4, n) ** 2).sum((1, 2)))
    print(f"  |WJ + (WJ)ᵀ| / |WJ| = {np.linalg.norm(A) / np.linalg.norm(S):.3e}; by depth:",
          ", ".join(f"{d:.3f} m {np.linalg.norm(rows_a[depth == d]) / np.linalg.norm(rows_s[depth == d]):.3e}" for d in layers))
