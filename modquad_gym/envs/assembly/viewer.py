"""Pictures of an assembly episode: ``rgb_array`` frames, ``ansi`` text grids and the ``human``
pygame window (the ``viz`` extra)."""

from __future__ import annotations

import os

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.envs.assembly.types import AssemblyState
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Cell, Structure

RENDER_FPS = 4


class AssemblyViewer:
    """Renders the states of one environment's grid.

    Args:
        radius: the grid's radius (n_max - 1); cells (x, y) with |x|, |y| <= radius.
        n_max: the largest module count (shown in the text header).
        size: (height, width) of ``rgb_array`` frames.
        palette: the module types of a mixed env (modules are then lettered A, B, ...), or None.
    """

    def __init__(
        self,
        radius: int,
        n_max: int,
        size: tuple[int, int] = (256, 256),
        palette: list[ModuleType] | None = None,
    ) -> None:
        self.radius = radius
        self.side = 2 * radius + 1
        self.n_max = n_max
        self.size = tuple(size)
        self.palette = palette
        self.window = None  # the pygame display of render_mode="human"
        self.clock = None

    def render(
        self,
        mode: str,
        state: AssemblyState,
        structure: Structure,
        status: np.ndarray | None,
        valid: set[Cell] = frozenset(),
    ) -> np.ndarray | str | None:
        """What ``env.render()`` returns in ``mode`` (``"human"`` shows the frame, None);
        ``status``: each task wrench satisfied or not, by the env's decision (the frame's strip;
        not read for ``"ansi"``); ``valid``: the cells where a module may dock (the text grid
        marks them)."""
        if mode == "ansi":
            return self.ansi(state, valid)
        frame = self.frame(structure, status)
        if mode == "rgb_array":
            return frame
        self.show(frame)
        return None

    def frame(self, structure: Structure, status: np.ndarray | None) -> np.ndarray:
        """The structure picture with a strip of each wrench's ``status`` (green: satisfied),
        (H, W, 3) uint8."""
        from modquad_gym.viz.raster import structure_image

        return structure_image(structure, size=self.size, wrench_status=status)

    def show(self, frame: np.ndarray) -> None:
        """Draw ``frame`` in a pygame window."""
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")  # no banner on import
        pygame = import_optional("pygame")
        if self.window is None:
            pygame.display.init()  # the display only: pygame.init() would open audio too
            pygame.display.set_caption("ModQuadAssembly")
            self.window = pygame.display.set_mode(frame.shape[1::-1])
            self.clock = pygame.time.Clock()
        pygame.event.pump()
        self.window.blit(pygame.surfarray.make_surface(frame.swapaxes(0, 1)), (0, 0))
        pygame.display.flip()
        self.clock.tick(RENDER_FPS)

    def close(self) -> None:
        """Close the pygame window, if open."""
        if self.window is not None:
            import pygame

            pygame.display.quit()
            pygame.quit()
            self.window = None

    def ansi(self, state: AssemblyState, valid: set[Cell]) -> str:
        """A text grid: ``@`` the initial module, ``#`` a module, ``+`` a cell in ``valid``
        (where a module may dock), ``.`` an empty one (with a palette, modules are letters:
        lower case for the initial one)."""
        r = self.radius
        occupied = set(state.cells)
        letters = {}
        if self.palette is not None:
            letters = {c: chr(65 + t) for c, t in zip(state.cells, state.types)}
        rows = [
            f"task {state.task.name!r} (t={len(state.task.W)}): {len(state.cells)}/{self.n_max}"
            f" modules, satisfied {state.frac:.3f}{' SUCCESS' if state.success else ''}"
        ]
        for y in range(r, -r - 1, -1):
            row = []
            for x in range(-r, r + 1):
                if (x, y) in letters:
                    row.append(letters[(x, y)].lower() if (x, y) == (0, 0) else letters[(x, y)])
                elif (x, y) == (0, 0):
                    row.append("@")
                elif (x, y) in occupied:
                    row.append("#")
                elif (x, y) in valid:
                    row.append("+")
                else:
                    row.append(".")
            rows.append(" ".join(row))
        if self.palette is not None:
            rows.append(", ".join(f"{chr(65 + k)} = {m.name}" for k, m in enumerate(self.palette)))
        return "\n".join(rows) + "\n"
