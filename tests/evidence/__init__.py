"""Tests of bayesnsi.evidence: likelihoods, priors, the marginal evidence and its estimators."""
