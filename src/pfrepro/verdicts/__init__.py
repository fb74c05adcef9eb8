"""One module per paper that decides its claims: ``record_claims(reg, results)``.

``pfrepro.verdicts.<key>`` turns the results of ``pfrepro.experiments.<key>.run_all`` into the
paper's claims (:class:`pfrepro.claims.ClaimsRegistry`), with the verdict rule of
:mod:`pfrepro.claims` and the estimators of :mod:`pfrepro.stats`. Nothing here runs an
experiment: every number a claim needs is in the results. Each module also names the paper's
main claims (``MAIN_CLAIMS``, the ones a chapter's findings list first) and generates the one
sentence a practitioner should take away (``takeaway(reg, results)``), from the claims.
The chapter and ``pfrepro run`` both call :meth:`pfrepro.papers.Paper.run`, so they decide
every claim in this one place.
"""
