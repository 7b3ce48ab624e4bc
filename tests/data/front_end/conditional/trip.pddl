; Home, office and shop; a book and a laptop at home, the briefcase too.
(define (problem trip)
  (:domain briefcase)
  (:objects home office shop - place book laptop - portable)
  (:init (case-at home) (at book home) (at laptop home))
  (:goal (and (at book office) (at laptop shop))))
