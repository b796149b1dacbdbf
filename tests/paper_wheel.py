"""The paper's wheel (Nandy & Xu: M = 2 kg, R = 0.17 m, k_diam = 0.25, k_axial = 0.4, earth) as
constants and as the scene text that tests build their effect scenes on."""
M, R, KA, KD, G = 2.0, 0.17, 0.4, 0.25, 9.81

PAPER_WHEEL_TOML = """
[wheel]
M = 2.0
R = 0.17
k_diam = 0.25
k_axial = 0.4
[effects.gravity]
g = 9.81
"""
