"""scikit-learn's estimator checks on every public estimator."""

from sklearn.utils.estimator_checks import parametrize_with_checks

from skmba import MultiResponseGP


@parametrize_with_checks([MultiResponseGP(), MultiResponseGP(noise=True)])
def test_sklearn_compatible_estimator(estimator, check):
    check(estimator)
