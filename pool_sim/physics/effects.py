"""The effects a scene may list, and the compile-time flags they become for the compiled
step (the forces themselves: kernels/effects.py)."""
from .kernels.layout import Listed

EFFECTS = ('gravity', 'buoyancy', 'drag', 'lift', 'added_mass', 'wave_radiation', 'contact',
           'friction', 'collisions')
DEFAULT_EFFECTS = ('gravity', 'buoyancy', 'drag', 'wave_radiation', 'contact', 'friction')
# The smooth effects, Listed's first fields (then the submerged-volume model, the loop's).
SMOOTH_EFFECTS = Listed._fields[:6]


def effect_flags(effects, submerged_volume='cap', scalar=True):
    """The compile-time flags the compiled functions branch on, a Listed (see
    kernels/layout.py): each smooth effect listed or not, cap for submerged_volume 'cap',
    and scalar."""
    unknown = set(effects) - set(EFFECTS)
    if unknown:
        raise ValueError(f'effects: unknown {sorted(unknown)}; allowed: {list(EFFECTS)}')
    if submerged_volume not in ('cap', 'linear'):
        raise ValueError(f"submerged_volume: 'cap' or 'linear', got {submerged_volume!r}")
    return Listed(*(name in effects for name in SMOOTH_EFFECTS), submerged_volume == 'cap',
                  bool(scalar))
