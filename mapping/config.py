"""Typed configuration of the continuous occupancy map, grouped the way the code is grouped."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator


class _Config(BaseModel):
    model_config = ConfigDict(extra="forbid")


class KernelConfig(_Config):
    """Initial hyperparameters and their bounds for one GP (eqs. 5-6), meters.

    The obstacle GP uses the Matérn kernel (eq. 5) only and ignores ``se_length``; the free
    GP multiplies a squared exponential (eq. 6) of length ``se_length`` by the Matérn.
    """

    nu: float = Field(1.5, description="Matérn smoothness: 0.5, 1.5 or 2.5")
    signal_var: float = Field(1.0, gt=0, description="prior variance of the latent function "
                              "(the scale of the ±1 targets; not fitted)")
    matern_length: float = Field(0.3, gt=0, description="Matérn characteristic length κ, m")
    se_length: float = Field(1.0, gt=0, description="squared-exponential length κ (free GP), m")
    noise_var: float = Field(0.05, gt=0, description="observation noise variance σn²")
    length_bounds: tuple[float, float] = Field((0.05, 2.0), description="bounds of the fitted "
                                               "Matérn length, m")
    se_bounds: tuple[float, float] = Field((0.1, 2.0), description="bounds of the fitted SE "
                                           "length (free GP), m")
    noise_floor: float = Field(0.01, gt=0, description="lowest fitted noise variance (+1-only "
                               "targets drive the fitted noise to zero without a floor)")

    @field_validator("nu")
    @classmethod
    def _matern_nu(cls, nu: float) -> float:
        if nu not in (0.5, 1.5, 2.5):
            raise ValueError(f"Matérn nu must be 0.5, 1.5 or 2.5, got {nu}")
        return nu

    @field_validator("length_bounds", "se_bounds")
    @classmethod
    def _bounds(cls, bounds: tuple[float, float]) -> tuple[float, float]:
        lo, hi = bounds
        if not 0 < lo < hi:
            raise ValueError(f"bounds must satisfy 0 < lo < hi, got {bounds}")
        return bounds


class ObstacleKernelConfig(KernelConfig):
    """θo of the obstacle GP (Matérn only); its own defaults, so a partial section keeps them."""

    matern_length: float = Field(0.2, gt=0, description="Matérn characteristic length κ, m")
    length_bounds: tuple[float, float] = Field((0.1, 0.3), description="bounds of the fitted "
                                               "Matérn length, m; the lower one at least "
                                               "training.voxel, the hits' spacing")


class FreeKernelConfig(KernelConfig):
    """θf of the free GP (SE × Matérn); its own defaults, so a partial section keeps them."""

    se_length: float = Field(0.5, gt=0, description="squared-exponential length κ, m")
    length_bounds: tuple[float, float] = Field((0.3, 0.5), description="bounds of the fitted "
                                               "Matérn length, m; the lower one at least "
                                               "training.free_voxel, the free points' spacing")
    se_bounds: tuple[float, float] = Field((0.3, 1.0), description="bounds of the fitted SE "
                                           "length, m; the lower one as for the Matérn's")


class TrainingConfig(_Config):
    """How a keyframe becomes training points (Section IV-A)."""

    max_range: float = Field(10.0, gt=0, description="meters; hits beyond count as no return "
                             "and give free points up to this range")
    free_step: float = Field(0.3, gt=0, description="spacing of free points along a beam, m")
    free_margin: float = Field(0.15, ge=0, description="free points stop this far before a hit, m")
    free_end: bool = Field(False, description="also put a free point at each beam's last free "
                           "point (free_margin before the hit, or the range limit)")
    voxel: float = Field(0.1, gt=0, description="hits are thinned to one per voxel of this "
                         "size, m")
    free_voxel: float = Field(0.3, gt=0, description="free points are thinned to one per voxel "
                              "of this size, m")


class QueryConfig(_Config):
    """The local query set (Section IV-A) and the local GPs that answer it."""

    resolution: float = Field(0.1, gt=0, description="map cell size, m")
    window: float = Field(20.0, gt=0, description="side of the square query window centred on "
                          "the sensor, m (the perception field)")
    near: float = Field(0.2, gt=0, description="only cells within this distance (m) of a training "
                        "point of the keyframe are queried")
    block: int = Field(5, ge=1, description="local GP blocks are block x block cells")
    margin: float = Field(1.0, ge=0, description="a block's GP uses training points up to this far "
                          "(m) outside the block")
    max_train: int = Field(16, ge=4, description="cap on training points per block and GP (the "
                           "nearest ones to the block centre)")
    max_cells: int = Field(9_000_000, ge=1, description="largest map (cells) the COM may grow "
                           "to; a pose far off (a bad pose) is rejected instead of exhausting memory")
    history: int = Field(2, ge=0, description="previous keyframes, nearest to the sensor, whose "
                         "points join the training set")


class SquashConfig(_Config):
    """Logistic squashing, eq. 7."""

    gamma: float = Field(10.0, gt=0, description="γ: weight w = γ·√λ")


class DriftConfig(_Config):
    """Map drift check, Section VII: the local map of each keyframe against the global COM."""

    threshold: float = Field(0.2, gt=0, description="cumulated excess Jensen-Shannon divergence "
                             "(nats per compared cell) that calls for regeneration")
    factor: float = Field(5.0, ge=1, description="an update's divergence up to this many times "
                          "the recent median is noise and is not cumulated")
    window: int = Field(50, ge=1, description="updates in that recent median")
    floor: float = Field(0.005, ge=0, description="smallest tolerated divergence, nats per cell")
    known: float = Field(0.1, ge=0, lt=0.5, description="cells compared: |Λ-0.5| > this in both")
    warmup: int = Field(10, ge=1, description="updates seen before anything is cumulated")
    unmoved: float = Field(0.01, ge=0, description="meters: a regeneration keeps a keyframe where "
                           "it was fused when none of its points moved this far (0: only a "
                           "keyframe whose pose is unchanged), and relearns only what the others reach; "
                           "0.01 m, a laser's range noise (σ of a SICK LMS and of the simulator): "
                           "a loop closure nudges most keyframes by less")


class COMConfig(_Config):
    """Everything the continuous occupancy map needs; the defaults work out of the box."""

    obstacle: ObstacleKernelConfig = ObstacleKernelConfig()
    free: FreeKernelConfig = FreeKernelConfig()
    fit_hyperparameters: bool = Field(True, description="fit θo, θf on the first keyframe by "
                                      "maximising the marginal likelihood, then keep them fixed")
    fit_max_points: int = Field(400, ge=10, description="points per GP used for that fit")
    training: TrainingConfig = TrainingConfig()
    query: QueryConfig = QueryConfig()
    squash: SquashConfig = SquashConfig()
    drift: DriftConfig = DriftConfig()
    seed: int = Field(0, ge=0, description="seed of every random draw (subsampling for the fit)")

    @model_validator(mode="after")
    def _lengths_span_the_training_spacing(self) -> COMConfig:
        """Each GP's lengths, fitted or not, are at least the spacing of its own training points
        (hits: ``training.voxel``; free points: ``training.free_voxel``). The map is read between
        those points; a shorter length leaves that space at the prior, unknown. A first frame
        where hits and free points interleave (clutter near the robot) pulls the ±1 fit down to
        0.08 m, and such a run then reads half of the space it has seen as unknown."""
        t = self.training
        for name, kc, spacing, key in (("obstacle", self.obstacle, t.voxel, "voxel"),
                                       ("free", self.free, t.free_voxel, "free_voxel")):
            lengths = {"matern_length": kc.matern_length, "length_bounds": kc.length_bounds[0]}
            if name == "free":
                lengths |= {"se_length": kc.se_length, "se_bounds": kc.se_bounds[0]}
            for field, length in lengths.items():
                if length < spacing:
                    raise ValueError(
                        f"{name}.{field}: {length} m is shorter than training.{key} = {spacing} m, "
                        f"the spacing of the {name} GP's training points")
        return self
