"""Layer 5, certification: certificates computed from a returned point, and the checks of
the paper's claims built on them."""
