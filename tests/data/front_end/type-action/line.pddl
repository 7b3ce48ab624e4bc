; Three spots in a line, the last the domain's constant `refill`.
(define (problem line)
  (:domain charging)
  (:objects home middle - spot pack_1 pack_2 - charge)
  (:init (robot-at home) (link home middle) (link middle home) (link middle refill) (link refill middle)
         (stored pack_1 middle) (stored pack_2 refill) (full pack_1)
         (= (total-cost) 0))
  (:goal (charged))
  (:metric minimize (total-cost)))
