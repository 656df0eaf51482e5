"""What both kinds of fit share: the calibration result type, ellipsoid and norm fits, integration, quantisation, regression, jackknife and other uncertainty, saturation, still detection."""
