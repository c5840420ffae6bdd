# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # Two elastic disks colliding head-on: the 2D version of `two_balls_3d.py`
#
# Two disks of the impact test (radius 20, plane strain, $\lambda = \mu = 20$,
# $\rho = 1$, P2), mirror images of each other, move towards each other along
# $y$ at speeds $\pm v_0$ without gravity, touch, push each other back and fly
# apart. The script is `demos/two_balls_3d.py` with `dim=2`; its notes explain
# the pairing and the check against one disk on a rigid plane.

from two_balls_3d import main

if __name__ == "__main__":
    main(dim=2, body="disk")
