; Four blocks: the tower d-c-b-a (a on the table) reversed into a-b-c-d (d on the table).
(define (problem bw-4)
  (:domain blocksworld)
  (:objects a b c d)
  (:init (arm-empty) (on-table a) (on b a) (on c b) (on d c) (clear d))
  (:goal (and (on a b) (on b c) (on c d))))
