(define (problem mugs-office)
  (:domain mugs)
  (:objects desk_a desk_b kitchen - place
            mug_0 - mug)
  (:init
    (robot-at kitchen) (hand-free) (at mug_0 kitchen) (sink kitchen)
    (= (total-cost) 0)
    (= (distance desk_a desk_b) 2) (= (distance desk_b desk_a) 2)
    (= (distance desk_a kitchen) 3) (= (distance kitchen desk_a) 3)
    (= (distance desk_b kitchen) 4) (= (distance kitchen desk_b) 4))
  (:goal (and (hand-free)))
  (:metric minimize (total-cost)))
