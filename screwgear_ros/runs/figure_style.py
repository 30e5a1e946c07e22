"""The figures' look, shared by the run plots and the paper report: matplotlib on the
Agg backend (no display needed), colour-blind safe colours and one set of rcParams."""

from __future__ import annotations

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # after the backend is chosen

#: Colours of the figures (colour-blind safe, Okabe–Ito).
COLORS = ('#0072B2', '#D55E00', '#009E73', '#CC79A7', '#E69F00', '#56B4E9', '#000000')

plt.rcParams.update({'figure.dpi': 110, 'font.size': 10, 'axes.grid': True,
                     'grid.alpha': 0.3, 'legend.fontsize': 9, 'axes.titlesize': 11})

__all__ = ['COLORS', 'plt']
