"""Integer codes shared by the component classes and the compiled kernel."""

# plant kinds
PLANT_HYPERSONIC, PLANT_WINGROCK, PLANT_MANIPULATOR, PLANT_SPACECRAFT = 0, 1, 2, 3
# controller kinds
CTRL_DIRECT, CTRL_ESTIMATION, CTRL_NUSSBAUM, CTRL_SIGN = 0, 1, 2, 3
# regressor kinds
REG_LINEAR_BIAS, REG_LINEAR, REG_FUZZY_NORMALISED, REG_FUZZY_RAW = 0, 1, 2, 3
