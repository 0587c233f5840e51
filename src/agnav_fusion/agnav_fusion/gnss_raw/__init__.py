"""Raw GNSS for the tightly coupled GNSS/INS (SPEC §7.7): observation epochs, satellite states from broadcast
ephemerides, double differences with their correlated covariance, a float DD baseline filter and integer fixing.

ROS-free: plain numpy arrays in, plain arrays out. RINEX reading and ephemeris maths come from cssrlib.
"""
