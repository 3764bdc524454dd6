"""Joubert's one-layer walls with continuity replaced by the negative adjoint of the
momentum equation's pressure gradient (J'_ρu = −W_ρ⁻¹ J_uρᵀ W_u): skew in the energy
weights by construction. What it costs: its divergence on linear velocity fields, layer
by layer, against Joubert's corrected continuity, and the low acoustic modes against
Adami's walls and the rigid box's analytic modes.

  python3 adjoint.py JOUBERT.bin ADAMI.bin

The two Jacobians from examples/wall_mode on the 6 × 10 × 6 closed box of its doc, corrected
(gradient_correction = true), with domain.wall_model = "joubert" and without;
adjoint-out.txt is its output (2026-12-07, after the fix that runs Adami's extrapolation
in RestState)."""
import sys
import numpy as np

def load(path):
    n = int(np.fromfile(path, '<u8', 1)[0])
    J = np.fromfile(path, '<f8', offset=8).reshape(n, n)
    side = np.loadtxt(path + '.txt')
    return J, side[:, :3], side[:, 3:].reshape(-1)

Jj, pos, w = load(sys.argv[1])
Ja, pos_a, w_a = load(sys.argv[2])
assert np.allclose(pos, pos_a)
n = Jj.shape[0]
rho = np.arange(0, n, 4)
vel = np.setdiff1d(np.arange(n), rho)
# blocks
for name, J in [("joubert", Jj), ("adami", Ja)]:
    print(f"{name}: |J_ρρ| {np.abs(J[np.ix_(rho, rho)]).max():.2e}, |J_uu| {np.abs(J[np.ix_(vel, vel)]).max():.2e}, "
          f"|J_ρu| {np.abs(J[np.ix_(rho, vel)]).max():.2e}, |J_uρ| {np.abs(J[np.ix_(vel, rho)]).max():.2e}")
Jp = Jj.copy()
G = Jj[np.ix_(vel, rho)]            # du/dt per ρ'
Jp[np.ix_(rho, vel)] = -(1.0 / w[rho])[:, None] * G.T * w[vel][None, :]
S = w[:, None] * Jp
print(f"adjoint: |WJ' + (WJ')ᵀ| / |WJ'| = {np.linalg.norm(S + S.T) / np.linalg.norm(S):.2e}")

lo, hi = pos.min(0), pos.max(0)
depth = np.round(np.minimum(pos - lo, hi - pos).min(1), 9)
layers = np.unique(depth)
centre = 0.5 * (lo + hi)
rho0 = 1000.0
# dρ'/dt = −ρ0 ∇·u for a linear field: each continuity's rows against it, by layer.
fields = {
    "u = (x − x_c, 0, 0), ∇·u = 1": lambda p: np.c_[p[:, 0] - centre[0], 0 * p[:, 0], 0 * p[:, 0]],
    "u = (y − y_c, 0, 0), ∇·u = 0 (shear)": lambda p: np.c_[p[:, 1] - centre[1], 0 * p[:, 0], 0 * p[:, 0]],
    "u = (0, y − y_c, 0), ∇·u = 1": lambda p: np.c_[0 * p[:, 0], p[:, 1] - centre[1], 0 * p[:, 0]],
    "u = (1, 0, 0) uniform, ∇·u = 0": lambda p: np.c_[1 + 0 * p[:, 0], 0 * p[:, 0], 0 * p[:, 0]],
}
exact = {k: (-rho0 if "= 1" in k.split(",")[-1] else 0.0) for k in fields}
for k, f in fields.items():
    x = np.zeros(n)
    x[vel] = f(pos).reshape(-1)
    print(k)
    for name, J in [("adami", Ja), ("joubert", Jj), ("adjoint", Jp)]:
        r = (J @ x)[rho]
        err = np.abs(r - exact[k])
        print(f"  {name:8s} max |dρ'/dt + ρ0 ∇·u| by depth (kg/m³/s):",
              ", ".join(f"{d:.2f} m {err[depth == d].max():.3g}" for d in layers))

c = 17.5
L = hi - lo + 0.02   # the fluid's extent: the outer particles stand δ/2 inside it
modes = sorted(c * np.pi * np.sqrt((l / L[0]) ** 2 + (m / L[1]) ** 2 + (q / L[2]) ** 2)
               for l in range(4) for m in range(4) for q in range(4) if l + m + q > 0)
print("rigid box (fluid extent", L, "m), lowest ω, rad/s:", ", ".join(f"{x:.1f}" for x in modes[:8]))
for name, J in [("adami", Ja), ("joubert", Jj), ("adjoint", Jp)]:
    lam = np.linalg.eigvals(J)
    om = np.sort(np.abs(lam.imag[lam.imag > 1e-6]))
    om = om[om > 1.0]
    print(f"{name:8s}: largest Re λ {lam.real.max():.3g} 1/s; lowest ω:", ", ".join(f"{x:.1f}" for x in om[:8]))

# The rigid box's smooth acoustic modes, ρ' = cos(lπx/Lx) cos(mπy/Ly) cos(qπz/Lz) on the
# particles (x from the fluid's edge): the frequency each operator gives it, from the
# Rayleigh quotient ω² = |J x|²_W / |x|²_W over x's pressure half (J maps ρ' to u and
# back; for a skew W J that is the mean of ω² over the eigenmodes x holds).
edge = lo - 0.01
print("smooth modes (l, m, q): analytic ω, then each operator's Rayleigh ω, rad/s")
for l, m, q in [(0, 1, 0), (1, 0, 0), (1, 1, 0), (0, 2, 0), (1, 1, 1)]:
    k = np.pi * np.array([l, m, q]) / L
    shape = np.prod(np.cos(k[None, :] * (pos - edge[None, :])), axis=1)
    x = np.zeros(n)
    x[rho] = shape
    om_exact = c * np.linalg.norm(k)
    out = []
    for name, J in [("adami", Ja), ("joubert", Jj), ("adjoint", Jp)]:
        y = J @ x
        q2 = (w * y * y).sum() / (w * x * x).sum()
        out.append(f"{name} {np.sqrt(q2):.1f}")
    print(f"  ({l}, {m}, {q}) {om_exact:.1f}:", ", ".join(out))

print("the pressure gradient of the (0, 1, 0) and (1, 1, 0) modes: max |du/dt − (−c²/ρ0 ∇ρ')| by depth, m/s² (the exact's max in brackets)")
for l, m, q in [(0, 1, 0), (1, 1, 0)]:
    k = np.pi * np.array([l, m, q]) / L
    arg = k[None, :] * (pos - edge[None, :])
    shape = np.prod(np.cos(arg), axis=1)
    grad = np.zeros_like(pos)
    for a in range(3):
        g = -k[a] * np.sin(arg[:, a])
        for b in range(3):
            if b != a:
                g = g * np.cos(arg[:, b])
        grad[:, a] = g
    want = -(c * c / rho0) * grad
    x = np.zeros(n)
    x[rho] = shape
    for name, J in [("adami", Ja), ("joubert", Jj)]:
        got = (J @ x)[vel].reshape(-1, 3)
        err = np.abs(got - want).max(1)
        print(f"  ({l},{m},{q}) {name:8s} [{np.abs(want).max():.3g}]:", ", ".join(f"{d:.2f} m {err[depth == d].max():.3g}" for d in layers))
    # −<x, J J x>_W / <x, x>_W: the frequency of the mode through both halves
    for name, J in [("adami", Ja), ("joubert", Jj), ("adjoint", Jp)]:
        q2 = -(w * x * (J @ (J @ x))).sum() / (w * x * x).sum()
        print(f"    {name}: ω from −<x, J²x> = {np.sqrt(abs(q2)):.1f}{' (negative)' if q2 < 0 else ''}")
