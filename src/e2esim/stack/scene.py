"""The multi-pass scene: the 3N x 3N polarimetric-interferometric covariance of a forest seen by a stack.

For passes m and n (ground-cancellation.md, eq. 4; Papathanassiou & Cloude 2001 for the RVoG blocks):

    C_mn = <s_m s_n^H> = gamma_vol(k_z,m - k_z,n) gamma_v(|t_m - t_n|) T_v + gamma_g(|t_m - t_n|) T_g,

with s_n = (S_hh, S_hv, S_vv) of pass n, T_v and T_g the volume and ground covariances of the single-pass
covariance C = T_v + T_g (``e2esim.stack.rvog.split_covariance``) and gamma_v, gamma_g the temporal coherences
(``e2esim.stack.temporal``). The diagonal blocks are C itself: the multi-pass scene reduces to the single-pass
Table I powers of Men et al. (2021). The volume coherence uses the incidence of the first pass.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.simulate import matrix_root
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.stack.acquisitions import AcquisitionStack
from e2esim.stack.rvog import ForestStructure, split_covariance
from e2esim.stack.temporal import TemporalDecorrelation


def stack_covariance(stack: AcquisitionStack, volume: np.ndarray, ground: np.ndarray, forest: ForestStructure,
                     temporal: TemporalDecorrelation) -> np.ndarray:
    """Eq. (4): the (3N, 3N) covariance from the volume and ground 3x3 covariances."""
    n = stack.passes
    gv = forest.coherence(stack.kz_difference(), float(stack.incidence_rad[0])) * temporal.volume(stack.lag_s())
    gg = temporal.ground(stack.lag_s())
    blocks = gv[:, :, None, None] * volume[None, None] + gg[:, :, None, None] * ground[None, None]  # (N, N, 3, 3)
    return blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)


class _StackBlocks:
    """Views of a (3N, 3N) stack covariance ``matrix`` (passes outer, channels (hh, hv, vv) inner)."""

    matrix: np.ndarray

    @property
    def passes(self) -> int:
        return self.matrix.shape[0] // 3

    def block(self, m: int, n: int) -> np.ndarray:
        """C_mn (3x3)."""
        return self.matrix[3 * m:3 * m + 3, 3 * n:3 * n + 3]

    def blocks(self) -> np.ndarray:
        """All blocks, shape (N, N, 3, 3)."""
        n = self.passes
        return self.matrix.reshape(n, 3, n, 3).transpose(0, 2, 1, 3)

    def channel_matrix(self, channel: int = 1) -> np.ndarray:
        """The N x N covariance of one channel (0 hh, 1 hv, 2 vv) across the passes."""
        return self.blocks()[:, :, channel, channel]

    def coherence(self, channel: int = 1) -> np.ndarray:
        """Inter-pass complex coherence of one channel, N x N."""
        c = self.channel_matrix(channel)
        d = np.sqrt(np.real(np.diag(c)))
        return c / np.outer(d, d)


@dataclass(frozen=True, eq=False)
class StackCovariance(_StackBlocks):
    """A bare (3N, 3N) stack covariance (e.g. the ground alone, for the cancellation residual)."""

    matrix: np.ndarray


@dataclass(frozen=True, eq=False)
class StackScene(_StackBlocks):
    """A forest seen by an acquisition stack: what ``scene.stack`` holds.

    acquisitions : the ``AcquisitionStack``. single_pass : the single-pass covariance (the case's
    ``scene.covariance``). forest : the RVoG structure. temporal : the temporal decorrelation model.
    volume, ground : T_v and T_g (3x3). matrix : the (3N, 3N) covariance of eq. (4), read-only.
    """

    acquisitions: AcquisitionStack
    single_pass: ScatteringCovariance
    forest: ForestStructure
    temporal: TemporalDecorrelation
    volume: np.ndarray = dataclasses.field(default=None, repr=False)
    ground: np.ndarray = dataclasses.field(default=None, repr=False)
    matrix: np.ndarray = dataclasses.field(default=None, repr=False)

    def __post_init__(self):
        tv, tg = split_covariance(self.single_pass, self.forest)
        m = stack_covariance(self.acquisitions, tv, tg, self.forest, self.temporal)
        m = 0.5 * (m + m.conj().T)
        w = np.linalg.eigvalsh(m)
        if w[0] < -1e-10 * w[-1]:
            raise PhysicsInputError(f"the stack covariance is not positive semi-definite (eigenvalue {w[0]:.3g})")
        for name, value in (("volume", tv), ("ground", tg), ("matrix", m)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    def replaced(self, **changes) -> StackScene:
        """The same scene with fields replaced (e.g. ``temporal=TemporalDecorrelation.none()``)."""
        keep = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in
                ("volume", "ground", "matrix")}
        return StackScene(**{**keep, **changes})

    def ground_only(self) -> StackCovariance:
        """The stack covariance of the ground alone (volume removed): what ground cancellation removes."""
        return StackCovariance(stack_covariance(self.acquisitions, np.zeros((3, 3)), self.ground, self.forest,
                                                self.temporal))

    def sample(self, rng: np.random.Generator, size) -> np.ndarray:
        """Joint scattering vectors of all passes ~ CN(0, C), shape ``size + (N, 3)``."""
        size = (size,) if np.isscalar(size) else tuple(size)

        root = matrix_root(self.matrix)
        xi = (rng.standard_normal(size + (3 * self.passes,)) + 1j * rng.standard_normal(size + (3 * self.passes,)))
        return (xi / np.sqrt(2) @ root.T).reshape(size + (self.passes, 3))

    def scalars(self) -> dict:
        """Output scalars (``stack.*``): the stack's, the forest height (m), the HV inter-pass coherence of the
        first pair and its volume and ground parts."""
        out = self.acquisitions.scalars()
        out["forest_height_m"] = float(self.forest.height_m)
        if self.passes > 1:
            out["hv_coherence_12"] = float(abs(self.coherence(1)[0, 1]))
        out["hv_ground_fraction"] = float(np.real(self.ground[1, 1]) / self.single_pass.sigma_hv)
        return out
